// The GPU sort matrix: for every distribution x size, rtoracle writes the keys, the GPU sorts them, rtoracle
// check-sort validates the dump; a table of case -> pass/fail with the oracle's diagnosis, exit 1 on any failure.
//   node gpu/run.js [--rtoracle PATH] [--dists a,b] [--sizes 1,2,3] [--repeat K] [--json FILE] [--keep DIR]
import {execFileSync, spawnSync} from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import {readNpy, writeNpy} from './lib/npy.js';
import {openDevice} from './lib/device.js';
import {bitonicSort} from './lib/sort.js';

const here = path.dirname(new URL(import.meta.url).pathname);
const opt = {rtoracle: path.join(here, '..', 'build', 'oracle', 'rtoracle'), repeat: 1,
  dists: 'uniform,one-bucket,clustered,clustered-far,line,two-clusters,random,entropy-15,few-unique,sentinel-heavy',
  sizes: '1,2,3,255,256,257,4095,4096,4097', json: null, keep: null};
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i++) {
  const name = argv[i].replace(/^--/, '');
  if (!(name in opt) || i + 1 >= argv.length) {
    console.error(`run.js: unknown option or missing value: ${argv[i]}`);
    process.exit(2);
  }
  opt[name] = argv[++i];
}
const repeat = Number(opt.repeat);
const dir = opt.keep || fs.mkdtempSync(path.join(os.tmpdir(), 'rto-gpu-'));
fs.mkdirSync(dir, {recursive: true});
const {device, backend, gpu} = await openDevice();
globalThis.rtoGpu = gpu; // the Dawn instance must outlive every object made from it

const results = [];
let failed = 0;
for (const dist of opt.dists.split(',')) {
  for (const size of opt.sizes.split(',').map(Number)) {
    const id = `bitonic-u32-${dist}-${size}`;
    const keysPath = path.join(dir, `${id}.keys.npy`), dumpPath = path.join(dir, `${id}.gpu.npy`);
    execFileSync(opt.rtoracle, ['keys', '--dist', dist, '--n', String(size), '-o', keysPath]);
    const keys = readNpy(keysPath).data;
    let passes = 0, diagnosis = '';
    for (let r = 0; r < repeat; r++) {
      writeNpy(dumpPath, await bitonicSort(device, keys));
      const check = spawnSync(opt.rtoracle, ['check-sort', '--input', keysPath, '--gpu', dumpPath, '--json',
        '--no-artifacts'], {encoding: 'utf8'});
      if (check.status === 0) passes++;
      else if (!diagnosis) {
        try {
          const rep = JSON.parse(check.stdout);
          diagnosis = rep.message || rep.fault;
        } catch {
          diagnosis = (check.stderr || check.stdout).trim().split('\n')[0];
        }
      }
    }
    const ok = passes === repeat;
    if (!ok) failed++;
    results.push({case: id, dist, size, passes, repeat, ok, diagnosis});
    console.log(`${id.padEnd(40)} ${ok ? 'pass' : 'FAIL'} ${passes}/${repeat}${diagnosis ? '  ' + diagnosis : ''}`);
  }
}
console.log(`${results.length - failed}/${results.length} cases pass on ${backend}`);
if (opt.json) fs.writeFileSync(opt.json, JSON.stringify({backend, results}, null, 2) + '\n');
if (!opt.keep) fs.rmSync(dir, {recursive: true, force: true});
process.exitCode = failed ? 1 : 0;
