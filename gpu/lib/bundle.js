// Reading an rtoracle bundle (manifest.json + .npy files) in a harness: arrays by file name, checked against the
// manifest's dtype and shape.
import fs from 'node:fs';
import path from 'node:path';
import {readNpy, wordsOf} from './npy.js';

export class Bundle {
  constructor(dir) {
    this.dir = dir;
    this.manifest = JSON.parse(fs.readFileSync(path.join(dir, 'manifest.json'), 'utf8'));
    if (this.manifest.format !== 'rtoracle-bundle') throw new Error(`${dir}: not an rtoracle bundle`);
    this.files = new Map(this.manifest.files.map((f) => [f.name, f]));
  }

  has(name) {
    return this.files.has(name);
  }

  /** readNpy of a listed file, its shape checked against the manifest. */
  npy(name) {
    const entry = this.files.get(name);
    if (!entry) throw new Error(`${this.dir}: the bundle has no ${name}`);
    const a = readNpy(path.join(this.dir, name));
    if (entry.shape && entry.shape.join(',') !== a.shape.join(','))
      throw new Error(`${this.dir}/${name}: shape (${a.shape}) is not the manifest's (${entry.shape})`);
    return a;
  }

  /** The raw little-endian bytes of a listed array (structured records included) as a Uint32Array of words. */
  words(name) {
    return wordsOf(this.npy(name).data);
  }
}
