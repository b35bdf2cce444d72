// Helpers for deliberative programs written in C or C++ (a world that
// includes `radar:reactive/deliberative`), as short as the Rust SDK's:
//
//     #include "radar_program.h"
//
//     static bool run(void) {
//         radar_connection_t c;
//         if (!radar_whenever("TestEvent", "TestResponse", &c)) return false;
//         radar_keep(c);                               // for the whole run
//         char payload[64];
//         return radar_waitfor("TestResponse.exited", 30, payload, sizeof payload) >= 0;
//     }
//
//     RADAR_PROGRAM(run)
//
// Every call that can fail returns false (or -1), and the host's message is
// kept for RADAR_PROGRAM, which ends the program with it. A connection is a
// handle: `radar_disconnect` ends it (C has no scopes that do it), and
// `radar_keep` keeps it for the rest of the run. Payloads are JSON text.
#ifndef RADAR_PROGRAM_H
#define RADAR_PROGRAM_H

#include "radar_guest.h"

#ifdef __cplusplus
extern "C" {
#endif

#define RADAR_OPTION_STRING RADAR_CAT(RADAR_WORLD, _option_string_t)

/// A live connection (or anonymous slot).
typedef radar_reactive_system_own_connection_t radar_connection_t;

/// What a start does while the response runs.
#define RADAR_BUSY_DROP RADAR_REACTIVE_SYSTEM_BUSY_DROP
#define RADAR_BUSY_QUEUE RADAR_REACTIVE_SYSTEM_BUSY_QUEUE
#define RADAR_BUSY_RESTART RADAR_REACTIVE_SYSTEM_BUSY_RESTART

/// A connection's properties (zeroed: none, drop, a queue of 1).
typedef struct {
    const char *until;   // a signal that interrupts what it starts, or NULL
    uint8_t busy;        // RADAR_BUSY_*
    uint32_t queue;      // with RADAR_BUSY_QUEUE: how many may wait (0: 1)
    double min_interval; // seconds under which a second emission is dropped (0: none)
} radar_link_options_t;

/// An anonymous slot's handler: the payload (JSON text) and its context.
typedef void (*radar_handler_t)(const char *payload, void *context);

// One copy for the whole program, whichever of its files include this
// header (weak: the linker keeps one).
#define RADAR_ONE_COPY __attribute__((weak))

/// The host's message of the last call that failed.
RADAR_ONE_COPY char radar_program_error_[512];

static inline bool radar_failed_(RADAR_STRING *err) {
    size_t n = err->len < sizeof radar_program_error_ - 1 ? err->len
                                                          : sizeof radar_program_error_ - 1;
    memcpy(radar_program_error_, err->ptr, n);
    radar_program_error_[n] = 0;
    RADAR_STRING_FREE(err);
    return false;
}

/// The host's message of the last call that failed.
static inline const char *radar_program_error(void) { return radar_program_error_; }

/// Connects `from` (`Plugin.signal`, or `Plugin` for its `triggered`) to
/// `to` (`Plugin.slot`, or `Plugin` for its `start`); `once` for the first
/// emission only. False if the system refuses (see radar_program_error).
static inline bool radar_connect(bool once, const char *from, const char *to,
                                 const radar_link_options_t *options, radar_connection_t *out) {
    char target[256];
    snprintf(target, sizeof target, strchr(to, '.') ? "%s" : "%s.start", to);
    radar_reactive_system_link_t link;
    memset(&link, 0, sizeof link);
    RADAR_STRING_SET(&link.source, from);
    RADAR_STRING_SET(&link.target, target);
    link.mode = once ? RADAR_REACTIVE_SYSTEM_MODE_ONCE : RADAR_REACTIVE_SYSTEM_MODE_WHENEVER;
    link.busy = options ? options->busy : RADAR_BUSY_DROP;
    link.queue_length = options && options->queue ? options->queue : 1;
    if (options && options->until) {
        link.until.is_some = true;
        RADAR_STRING_SET(&link.until.val, options->until);
    }
    if (options && options->min_interval > 0) {
        link.min_interval_ns.is_some = true;
        link.min_interval_ns.val = radar_nanos(options->min_interval);
    }
    RADAR_STRING err;
    return radar_reactive_system_connect(&link, out, &err) || radar_failed_(&err);
}

/// `whenever from to`.
static inline bool radar_whenever(const char *from, const char *to, radar_connection_t *out) {
    return radar_connect(false, from, to, NULL, out);
}

/// `once from to`.
static inline bool radar_once(const char *from, const char *to, radar_connection_t *out) {
    return radar_connect(true, from, to, NULL, out);
}

/// The anonymous slots' handlers, by connection id.
#define RADAR_MAX_SLOTS 32
struct radar_slot_ {
    uint64_t id;
    radar_handler_t handler;
    void *context;
};
RADAR_ONE_COPY struct radar_slot_ radar_slots_[RADAR_MAX_SLOTS];

static inline uint64_t radar_first_id_(radar_connection_t c) {
    RADAR_CAT(RADAR_WORLD, _list_u64_t) ids;
    radar_reactive_system_method_connection_ids(radar_reactive_system_borrow_connection(c), &ids);
    uint64_t id = ids.len > 0 ? ids.ptr[0] : 0;
    RADAR_CAT(RADAR_WORLD, _list_u64_free)(&ids);
    return id;
}

/// Ends a connection or an anonymous slot now.
static inline void radar_disconnect(radar_connection_t c) {
    uint64_t id = radar_first_id_(c);
    for (int i = 0; i < RADAR_MAX_SLOTS; i++) {
        if (radar_slots_[i].handler && radar_slots_[i].id == id) radar_slots_[i].handler = NULL;
    }
    radar_reactive_system_connection_drop_own(c);
}

/// Keeps a connection for the rest of the run; the handle is spent.
static inline void radar_keep(radar_connection_t c) {
    radar_reactive_system_method_connection_keep(radar_reactive_system_borrow_connection(c));
    radar_reactive_system_connection_drop_own(c);
}

/// An anonymous slot: `handler(payload, context)` runs at every emission of
/// `signal` (`once`: the first), while the program waits, at the time of the
/// delivery. At most RADAR_MAX_SLOTS at once.
static inline bool radar_on(bool once, const char *signal, radar_handler_t handler,
                            void *context, radar_connection_t *out) {
    RADAR_STRING name, err;
    RADAR_STRING_SET(&name, signal);
    radar_reactive_system_mode_t mode =
        once ? RADAR_REACTIVE_SYSTEM_MODE_ONCE : RADAR_REACTIVE_SYSTEM_MODE_WHENEVER;
    if (!radar_reactive_system_listen(&name, mode, out, &err)) return radar_failed_(&err);
    for (int i = 0; i < RADAR_MAX_SLOTS; i++) {
        if (!radar_slots_[i].handler) {
            radar_slots_[i].id = radar_first_id_(*out);
            radar_slots_[i].handler = handler;
            radar_slots_[i].context = context;
            return true;
        }
    }
    radar_reactive_system_connection_drop_own(*out);
    snprintf(radar_program_error_, sizeof radar_program_error_,
             "more than %d anonymous slots at once", RADAR_MAX_SLOTS);
    return false;
}

/// Waits until `deadline` (ns, or none), or for `signal` (or none), running
/// the anonymous slots' handlers as their deliveries come. 1 with the
/// signal's payload in `payload`, 0 at the deadline, -1 on an error.
static inline int radar_wait_(const uint64_t *deadline, const char *signal, char *payload,
                              size_t size) {
    for (;;) {
        uint64_t at = deadline ? *deadline : 0;
        RADAR_STRING name, err;
        if (signal) RADAR_STRING_SET(&name, signal);
        radar_reactive_system_woke_t woke;
        if (!radar_reactive_system_wait(deadline ? &at : NULL, signal ? &name : NULL, &woke, &err)) {
            radar_failed_(&err);
            return -1;
        }
        if (woke.tag == RADAR_REACTIVE_SYSTEM_WOKE_DEADLINE) return 0;
        if (woke.tag == RADAR_REACTIVE_SYSTEM_WOKE_SIGNAL) {
            if (payload && size > 0) {
                size_t n = woke.val.signal.len < size - 1 ? woke.val.signal.len : size - 1;
                memcpy(payload, woke.val.signal.ptr, n);
                payload[n] = 0;
            }
            radar_reactive_system_woke_free(&woke);
            return 1;
        }
        radar_reactive_system_delivery_t *d = &woke.val.delivery;
        char *text = (char *)malloc(d->payload.len + 1);
        memcpy(text, d->payload.ptr, d->payload.len);
        text[d->payload.len] = 0;
        for (int i = 0; i < RADAR_MAX_SLOTS; i++) {
            if (radar_slots_[i].handler && radar_slots_[i].id == d->connection) {
                radar_slots_[i].handler(text, radar_slots_[i].context);
                break;
            }
        }
        free(text);
        radar_reactive_system_woke_free(&woke);
    }
}

/// Waits `seconds` of the system's time; anonymous slots run meanwhile.
static inline bool radar_program_sleep(double seconds) {
    uint64_t deadline = radar_reactive_system_now() + radar_nanos(seconds);
    return radar_wait_(&deadline, NULL, NULL, 0) >= 0;
}

/// Waits for `signal`: 1 with its payload (JSON) in `payload`, 0 when
/// `timeout` seconds pass first (a negative timeout: none), -1 on an error.
static inline int radar_waitfor(const char *signal, double timeout, char *payload, size_t size) {
    uint64_t deadline = radar_reactive_system_now() + radar_nanos(timeout);
    return radar_wait_(timeout < 0 ? NULL : &deadline, signal, payload, size);
}

/// The system's time in seconds since the run began.
static inline double radar_program_now(void) { return (double)radar_reactive_system_now() / 1e9; }

/// Sends `json` straight into `slot` (`Plugin.slot`).
static inline bool radar_inject(const char *slot, const char *json) {
    RADAR_STRING s, p, err;
    RADAR_STRING_SET(&s, slot);
    RADAR_STRING_SET(&p, json);
    return radar_reactive_system_inject(&s, &p, &err) || radar_failed_(&err);
}

/// Ends the program at once (it does not return) and the run with it, with
/// `status` for `radar run` to exit with (0: success): every running
/// response runs its exit, nothing new begins. Returning from the program
/// (`RADAR_PROGRAM`'s function) ends the run too (status 0, or 1 with its
/// error), unless it kept connections.
static inline void radar_stop(uint8_t status) { radar_reactive_system_stop(status); }

/// Writes a blackboard entry (JSON, checked against its type).
static inline bool radar_board_write(const char *entry, const char *json) {
    RADAR_STRING e, v, err;
    RADAR_STRING_SET(&e, entry);
    RADAR_STRING_SET(&v, json);
    return radar_reactive_system_board_write(&e, &v, &err) || radar_failed_(&err);
}

/// A blackboard entry's value (JSON) into `out`: 1, or 0 if nothing wrote
/// it yet, or -1 on an error.
static inline int radar_board_read(const char *entry, char *out, size_t size) {
    RADAR_STRING e, err;
    RADAR_OPTION_STRING value;
    RADAR_STRING_SET(&e, entry);
    if (!radar_reactive_system_board_read(&e, &value, &err)) {
        radar_failed_(&err);
        return -1;
    }
    if (!value.is_some) return 0;
    size_t n = value.val.len < size - 1 ? value.val.len : size - 1;
    memcpy(out, value.val.ptr, n);
    out[n] = 0;
    RADAR_STRING_FREE(&value.val);
    return 1;
}

/// A plugin's state (`inactive`, `active`, `idle`, `running`, ...) into `out`.
static inline bool radar_plugin_state(const char *plugin, char *out, size_t size) {
    RADAR_STRING p, state, err;
    RADAR_STRING_SET(&p, plugin);
    if (!radar_reactive_system_plugin_state(&p, &state, &err)) return radar_failed_(&err);
    size_t n = state.len < size - 1 ? state.len : size - 1;
    memcpy(out, state.ptr, n);
    out[n] = 0;
    RADAR_STRING_FREE(&state);
    return true;
}

/// Makes `body` (a `bool body(void)`) the world's `run`: false ends the
/// program with the message of the call that failed (or of radar_fail).
#ifdef __cplusplus
#define RADAR_EXTERN_C extern "C"
#else
#define RADAR_EXTERN_C
#endif
#define RADAR_PROGRAM(body)                                                    \
    RADAR_EXTERN_C bool RADAR_CAT(RADAR_CAT(exports_, RADAR_WORLD), _run)(RADAR_STRING * err) { \
        if (body()) return true;                                               \
        RADAR_CAT(RADAR_WORLD, _string_dup)(err, radar_program_error_);        \
        return false;                                                          \
    }

/// Sets the message the program ends with; returns false.
static inline bool radar_fail(const char *message) {
    snprintf(radar_program_error_, sizeof radar_program_error_, "%s", message);
    return false;
}

#ifdef __cplusplus
}
#endif

#endif
