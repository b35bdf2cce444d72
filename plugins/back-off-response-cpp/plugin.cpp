// BackOff, in C++: `start(speed)` sends a whole Twist backing away at
// `speed` (its signal `cmd-vel`), says so (`moving`), keeps the command on
// the blackboard (`last-command`) and backs away for `back_s` seconds
// (default 1); `exit` sends the zero Twist, whatever ended the activation.
// The world is `plugins/wit/back-off`, shared with Rust, Python,
// JavaScript and C: records are the C bindings' structs, a variant a
// tagged union.
#include "radar_guest.h"

namespace {

using Twist = radar_examples_back_off_commands_twist_t;
using Motion = radar_examples_back_off_commands_motion_t;

void command(double forward) {
    Twist twist{};
    twist.linear.x = forward;
    radar_examples_back_off_signals_cmd_vel(&twist);
    radar_examples_back_off_board_write_last_command(&twist);
}

void moving(uint8_t tag, double speed) {
    Motion now{};
    now.tag = tag;
    now.val.reversing = speed;
    radar_examples_back_off_signals_moving(&now);
}

} // namespace

extern "C" bool exports_radar_examples_back_off_slots_start(double speed,
                                                            radar_interruption_t *err) {
    command(-speed);
    moving(RADAR_EXAMPLES_BACK_OFF_COMMANDS_MOTION_REVERSING, speed);
    return radar_sleep(radar_config_f64("back_s", 1.0), err); // an interruption ends `start`
}

extern "C" void exports_radar_examples_back_off_slots_exit(void) {
    command(0.0);
    moving(RADAR_EXAMPLES_BACK_OFF_COMMANDS_MOTION_STOPPED, 0.0);
    radar_info("motors stopped");
}
