// BackOff, in C: `start(speed)` sends a whole Twist backing away at `speed`
// (its signal `cmd-vel`), says so (`moving`), keeps the command on the
// blackboard (`last-command`) and backs away for `back_s` seconds (default
// 1); `exit` sends the zero Twist, whatever ended the activation. The world
// is `plugins/wit/back-off`, shared with Rust, Python and JavaScript:
// records are C structs, a variant a tagged union.
#include "radar_guest.h"

typedef radar_examples_back_off_commands_twist_t twist_t;
typedef radar_examples_back_off_commands_motion_t motion_t;

static void command(double forward) {
    twist_t twist = {0};
    twist.linear.x = forward;
    radar_examples_back_off_signals_cmd_vel(&twist);
    radar_examples_back_off_board_write_last_command(&twist);
}

bool exports_radar_examples_back_off_slots_start(double speed, radar_interruption_t *err) {
    command(-speed);
    motion_t now = {.tag = RADAR_EXAMPLES_BACK_OFF_COMMANDS_MOTION_REVERSING};
    now.val.reversing = speed;
    radar_examples_back_off_signals_moving(&now);
    return radar_sleep(radar_config_f64("back_s", 1.0), err); // an interruption ends `start`
}

void exports_radar_examples_back_off_slots_exit(void) {
    command(0.0);
    motion_t now = {.tag = RADAR_EXAMPLES_BACK_OFF_COMMANDS_MOTION_STOPPED};
    radar_examples_back_off_signals_moving(&now);
    radar_info("motors stopped");
}
