// Running rtoracle from a harness: generating inputs and bundles, and validating dumps with its check-* commands.
import {spawnSync} from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

const here = path.dirname(new URL(import.meta.url).pathname);
export const REPO = path.join(here, '..', '..');
export const DEFAULT_RTORACLE = path.join(REPO, 'build', 'oracle', 'rtoracle');

/** A scene file as given (absolute, or relative to the working directory), else relative to the repository root
 * (its fixtures); a procedural scene name as it is. */
export function scenePath(scene) {
  if (!/[/.]/.test(scene) || path.isAbsolute(scene) || fs.existsSync(scene)) return scene;
  return path.join(REPO, scene);
}

/** Bad usage of gpu/run (its options, or a family's reading of them): one line on stderr, exit status 2. */
export function usage(msg) {
  console.error(`gpu/run: ${msg} (gpu/run --help)`);
  process.exit(2);
}

/** Runs `rtoracle ARGS...` and throws with its message unless it exits 0 (for commands that write inputs). */
export function rtoracle(bin, args) {
  const r = spawnSync(bin, args, {encoding: 'utf8', maxBuffer: 64 << 20});
  if (r.error) throw new Error(`${bin}: ${r.error.message}`);
  if (r.status !== 0) throw new Error(`rtoracle ${args[0]}: ${(r.stderr || r.stdout).trim().split('\n')[0]}`);
  return r.stdout;
}

/** Runs `rtoracle CHECK ARGS... --json` on a dump: {pass, status, diagnosis, fault, report}. pass is exit status 0;
 * diagnosis is the report's one-line message (or the error line for status 2, bad input). */
export function check(bin, command, args) {
  const r = spawnSync(bin, [command, ...args, '--json'], {encoding: 'utf8', maxBuffer: 256 << 20});
  if (r.error) throw new Error(`${bin}: ${r.error.message}`);
  let report = null;
  try {
    report = JSON.parse(r.stdout);
  } catch {
    report = null;
  }
  const diagnosis = r.status === 0 ? '' : report && report.message ? report.message
    : (r.stderr || r.stdout).trim().split('\n')[0];
  return {pass: r.status === 0, status: r.status, diagnosis, fault: report ? report.fault || null : null, report};
}

/** --scenes: every scene named must load (rtoracle info), else one line and exit status 2 before any case runs. */
export function checkScenes(bin, scenes) {
  for (const s of scenes) {
    const r = spawnSync(bin, ['info', scenePath(s)], {encoding: 'utf8'});
    if (r.status !== 0) {
      console.error(`gpu/run: --scenes: ${(r.stderr || r.stdout || String(r.error)).trim().split('\n')[0]}`);
      process.exit(2);
    }
  }
}
