// Writes Radar's JavaScript development runtime for a world:
//
//     node dev_runtime.js WIT_DIR WORLD RADAR_DEV_JS OUT_JS
//
// Reads the world from the .wit files of WIT_DIR (not its deps/). Each
// interface it imports (its own, `import board;`, a full name, `import
// radar:reactive/clock@0.1.0;`, and those of `radar:reactive` that every
// plugin world includes) is imported as a namespace and offered to the
// script under its specifier. Each `export`: a function (`export check: func(...)`) becomes an exported
// function, an interface (`export slots;`) an exported object with one
// method per function of the interface; each hands the call to the
// plugin's own export of the same name (see radar_dev.js). WIT names are
// kebab-case; their JavaScript names are camelCase, as jco makes them.
const fs = require('fs');
const path = require('path');

const [witDir, world, runtime, out] = process.argv.slice(2);
const text = fs
    .readdirSync(witDir)
    .filter((f) => f.endsWith('.wit'))
    .map((f) => fs.readFileSync(path.join(witDir, f), 'utf8'))
    .join('\n')
    .replace(/\/\/.*$/gm, '');

const camel = (name) => name.replace(/-([a-z0-9])/g, (_, c) => c.toUpperCase());

function block(kind, name) {
    const start = text.search(new RegExp(`\\b${kind}\\s+${name}\\s*\\{`));
    if (start < 0) throw new Error(`no ${kind} ${name} in ${witDir}`);
    let depth = 0;
    for (let i = text.indexOf('{', start); i < text.length; i++) {
        if (text[i] === '{') depth++;
        if (text[i] === '}' && --depth === 0) return text.slice(text.indexOf('{', start) + 1, i);
    }
    throw new Error(`unclosed ${kind} ${name}`);
}

const pkg = (text.match(/\bpackage\s+([a-z][\w-]*:[a-z][\w-]*)(@[\w.+-]+)?\s*;/) || []).slice(1);
const worldText = block('world', world);
const imports = [];
const reactive = worldText.match(/include\s+radar:reactive\/([a-z-]+)(@[\w.+-]+)/);
const program = world === 'deliberative' || (reactive && reactive[1] === 'deliberative');
if (reactive || world === 'deliberative') {
    // What the included world imports: a program's the system, a plugin's
    // the clock.
    const version = reactive ? reactive[2] : '@0.1.0';
    for (const name of [program ? 'system' : 'clock', 'logging', 'config']) {
        imports.push(`radar:reactive/${name}${version}`);
    }
}
for (const m of worldText.matchAll(/(?:^|[;{\s])import\s+([a-z][\w:/@.-]*)\s*;/g)) {
    imports.push(m[1].includes(':') ? m[1] : `${pkg[0]}/${m[1]}${pkg[1] || ''}`);
}
let text0 = fs.readFileSync(runtime, 'utf8');
if (program) text0 = text0.split("'./radar_guest.js';").join("'./radar_program.js';");
const lines = [text0];
[...new Set(imports)].forEach((spec, i) => {
    lines.push(`import * as __world${i} from ${JSON.stringify(spec)};`);
    lines.push(`WORLD_IMPORTS[${JSON.stringify(spec)}] = __world${i};`);
});
for (const m of worldText.matchAll(/export\s+([a-z][\w-]*)\s*(:\s*func)?/g)) {
    const name = camel(m[1]);
    if (m[2]) {
        lines.push(`export function ${name}(...args) { return plugin().${name}(...args); }`);
        continue;
    }
    const functions = [...block('interface', m[1]).matchAll(/([a-z][\w-]*)\s*:\s*func/g)].map((f) => camel(f[1]));
    lines.push(`export const ${name} = {`);
    for (const f of functions) lines.push(`    ${f}(...args) { return plugin().${name}.${f}(...args); },`);
    lines.push('};');
}
// The deliberative world's own export, when the world includes it.
if (program && !/export\s+run\b/.test(worldText)) {
    lines.push('export function run(...args) { return plugin().run(...args); }');
}
fs.writeFileSync(out, lines.join('\n') + '\n');
