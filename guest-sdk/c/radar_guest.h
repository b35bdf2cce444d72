// Helpers for Radar plugins written in C or C++ (built by `build` beside
// this file, with wit-bindgen's C bindings of the plugin's world). The
// bindings are complete but low level: nanoseconds, WIT strings, text-only
// configuration. These make the usual things short:
//
//     #include "radar_guest.h"
//
//     bool exports_my_event_check(uint32_t *ret) {
//         if (!radar_sleep(radar_config_f64("interval_s", 1.0), NULL))
//             return false;                       // deactivated meanwhile
//         radar_info("checked");
//         *ret = 42;
//         return true;                            // triggers with 42
//     }
//
// `radar_world.h`, written by the build next to the bindings, includes the
// world's header (`my_event.h`, whose exports the plugin defines) and names
// the world for these helpers (RADAR_WORLD). Everything here is `static
// inline`: include it from any file.
#ifndef RADAR_GUEST_H
#define RADAR_GUEST_H

#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "radar_world.h"

#define RADAR_CAT_(a, b) a##b
#define RADAR_CAT(a, b) RADAR_CAT_(a, b)
// The world's string type and its functions (`my_event_string_t`, ...).
#define RADAR_STRING RADAR_CAT(RADAR_WORLD, _string_t)
#define RADAR_STRING_SET RADAR_CAT(RADAR_WORLD, _string_set)
#define RADAR_STRING_FREE RADAR_CAT(RADAR_WORLD, _string_free)

#ifdef __cplusplus
extern "C" {
#endif

/// Why the host asked the running slot to stop.
typedef radar_reactive_types_interruption_t radar_interruption_t;
#define RADAR_INTERRUPT RADAR_REACTIVE_TYPES_INTERRUPTION_INTERRUPT
#define RADAR_EXIT RADAR_REACTIVE_TYPES_INTERRUPTION_EXIT
#define RADAR_DEACTIVATE RADAR_REACTIVE_TYPES_INTERRUPTION_DEACTIVATE

/// Log levels.
typedef radar_reactive_types_level_t radar_level_t;
#define RADAR_TRACE RADAR_REACTIVE_TYPES_LEVEL_TRACE
#define RADAR_DEBUG RADAR_REACTIVE_TYPES_LEVEL_DEBUG
#define RADAR_INFO RADAR_REACTIVE_TYPES_LEVEL_INFO
#define RADAR_WARN RADAR_REACTIVE_TYPES_LEVEL_WARN
#define RADAR_ERROR RADAR_REACTIVE_TYPES_LEVEL_ERROR

/// Seconds as whole nanoseconds (never negative).
static inline uint64_t radar_nanos(double seconds) {
    return seconds > 0 ? (uint64_t)(seconds * 1e9) : 0;
}

// A plugin's clock; a program's world has the system's instead
// (radar_program.h).
#ifndef RADAR_PROGRAM_WORLD

/// Scheduler time in seconds since the system began to run.
static inline double radar_now(void) {
    return (double)radar_reactive_clock_now() / 1e9;
}

/// Waits `nanos` of scheduler time (virtual in tests). False if the host
/// asked the running slot to stop meanwhile; then `*why` (if not NULL) is
/// the reason, for a slot to return as its error.
static inline bool radar_sleep_nanos(uint64_t nanos, radar_interruption_t *why) {
    radar_interruption_t reason;
    if (radar_reactive_clock_sleep(nanos, &reason)) return true;
    if (why) *why = reason;
    return false;
}

/// `radar_sleep_nanos` in seconds.
static inline bool radar_sleep(double seconds, radar_interruption_t *why) {
    return radar_sleep_nanos(radar_nanos(seconds), why);
}

/// Lets every other task ready at this instant run first; false if
/// interrupted (as `radar_sleep_nanos`).
static inline bool radar_yield(radar_interruption_t *why) {
    radar_interruption_t reason;
    if (radar_reactive_clock_yield(&reason)) return true;
    if (why) *why = reason;
    return false;
}

#endif // RADAR_PROGRAM_WORLD

/// Records `message` in the trace at `level`.
static inline void radar_log(radar_level_t level, const char *message) {
    RADAR_STRING text;
    RADAR_STRING_SET(&text, message);
    radar_reactive_logging_log(level, &text);
}

/// `radar_log` with a printf format (a line of at most 1023 bytes).
static inline void radar_logf(radar_level_t level, const char *format, ...) {
    char line[1024];
    va_list args;
    va_start(args, format);
    vsnprintf(line, sizeof line, format, args);
    va_end(args);
    radar_log(level, line);
}

#define radar_info(...) radar_logf(RADAR_INFO, __VA_ARGS__)
#define radar_debug(...) radar_logf(RADAR_DEBUG, __VA_ARGS__)
#define radar_warn(...) radar_logf(RADAR_WARN, __VA_ARGS__)
#define radar_error(...) radar_logf(RADAR_ERROR, __VA_ARGS__)

/// The configuration value `key` as text into `out` (at most `size` bytes
/// with its NUL); false if it is missing.
static inline bool radar_config_text(const char *key, char *out, size_t size) {
    RADAR_STRING name, value;
    RADAR_STRING_SET(&name, key);
    if (!radar_reactive_config_get(&name, &value)) return false;
    size_t n = value.len < size - 1 ? value.len : size - 1;
    memcpy(out, value.ptr, n);
    out[n] = 0;
    RADAR_STRING_FREE(&value);
    return true;
}

/// The configuration value `key` as a number; `fallback` if it is missing
/// or is not a number.
static inline double radar_config_f64(const char *key, double fallback) {
    char text[64], *end;
    if (!radar_config_text(key, text, sizeof text)) return fallback;
    double value = strtod(text, &end);
    return end != text && *end == 0 ? value : fallback;
}

/// The configuration value `key` as a whole number; `fallback` if it is
/// missing or is not one (`5.0` is not).
static inline int64_t radar_config_i64(const char *key, int64_t fallback) {
    char text[64], *end;
    if (!radar_config_text(key, text, sizeof text)) return fallback;
    long long value = strtoll(text, &end, 10);
    return end != text && *end == 0 ? (int64_t)value : fallback;
}

/// The configuration value `key` as a yes or no (`true`, `1`, `yes`);
/// `fallback` if it is missing.
static inline bool radar_config_bool(const char *key, bool fallback) {
    char text[16];
    if (!radar_config_text(key, text, sizeof text)) return fallback;
    return strcmp(text, "true") == 0 || strcmp(text, "1") == 0 || strcmp(text, "yes") == 0;
}

/// Hot swap, in a world that exports `snapshot: func() -> list<u8>` and
/// `restore: func(state: list<u8>) -> result<_, string>`: a plain struct
/// (no pointers) as the state a new version takes over.
///
///     static struct { uint32_t count; } state;
///     void exports_my_event_snapshot(my_event_list_u8_t *ret) { RADAR_SAVE(state, ret); }
///     bool exports_my_event_restore(my_event_list_u8_t *saved, my_event_string_t *err) {
///         return RADAR_RESTORE(state, saved, err);
///     }
///
/// A version whose struct has another size refuses the old bytes (`restore
/// returned an error: the old version's state does not fit: ...`), and the
/// swap rolls back.
#define RADAR_SAVE(state, ret)                                                 \
    do {                                                                       \
        (ret)->len = sizeof(state);                                            \
        (ret)->ptr = (uint8_t *)malloc(sizeof(state));                         \
        memcpy((ret)->ptr, &(state), sizeof(state));                           \
    } while (0)
#define RADAR_RESTORE(state, saved, err)                                       \
    (radar_state_fits_(sizeof(state), (saved)->len, (err))                     \
         ? (memcpy(&(state), (saved)->ptr, sizeof(state)),                     \
            RADAR_CAT(RADAR_WORLD, _list_u8_free)(saved), true)                \
         : (RADAR_CAT(RADAR_WORLD, _list_u8_free)(saved), false))

static inline bool radar_state_fits_(size_t size, size_t len, RADAR_STRING *err) {
    char why[160];
    if (size == len) return true;
    snprintf(why, sizeof why,
             "the old version's state does not fit: %zu bytes, this version keeps %zu", len,
             size);
    RADAR_CAT(RADAR_WORLD, _string_dup)(err, why);
    return false;
}

#ifdef __cplusplus
}
#endif

#endif
