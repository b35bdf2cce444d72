// Logging and configuration for every Radar component written in
// JavaScript: a plugin's helpers (radar_guest.js) and a deliberative
// program's (radar_program.js) both offer these; import them from either.
import { log as hostLog } from 'radar:reactive/logging@0.1.0';
import { get, keys } from 'radar:reactive/config@0.1.0';

export function log(level, message) { hostLog(level, message); }
export function trace(message) { hostLog('trace', message); }
export function debug(message) { hostLog('debug', message); }
export function info(message) { hostLog('info', message); }
export function warn(message) { hostLog('warn', message); }
export function error(message) { hostLog('error', message); }

/**
 * The configuration value `key`, parsed as the type of `fallback` (text if
 * there is none); `fallback` if it is missing or does not parse.
 */
export function config(key, fallback) {
    const text = get(key);
    if (text === undefined || text === null) return fallback;
    if (fallback === undefined || typeof fallback === 'string') return text;
    if (typeof fallback === 'boolean') return ['true', '1', 'yes'].includes(text.trim().toLowerCase());
    if (typeof fallback === 'number') {
        const value = Number(text);
        return Number.isNaN(value) ? fallback : value;
    }
    return text;
}

/** Every configured key, sorted. */
export function configKeys() {
    return keys();
}

