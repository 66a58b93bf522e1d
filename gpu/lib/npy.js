// Reading and writing NumPy .npy files (format 1.0 / 2.0, little-endian) for GPU harnesses: plain arrays of
// u8/u16/f16 (raw bits)/u32/i32/f32/u64 and rtoracle's structured records (read as raw bytes plus the parsed descr). No dependencies;
// lift this file into your own harness.
import fs from 'node:fs';

const MAGIC = Buffer.from([0x93, 0x4e, 0x55, 0x4d, 0x50, 0x59]);
// '<f2' is read and written as its raw bits (a Uint16Array): writeNpy needs descr '<f2' for binary16 data.
const TYPES = {'<u1': Uint8Array, '|u1': Uint8Array, '<u2': Uint16Array, '<f2': Uint16Array, '<u4': Uint32Array,
               '<i4': Int32Array, '<f4': Float32Array, '<u8': BigUint64Array};

/** Reads a .npy file: {descr, shape, data} where data is a typed array for plain dtypes, a Uint8Array of the raw
 * records for structured ones (descr is then the header's list text). Throws with one line on anything malformed. */
export function readNpy(path) {
  const buf = fs.readFileSync(path);
  if (buf.length < 10 || !buf.subarray(0, 6).equals(MAGIC)) throw new Error(`${path}: not a .npy file`);
  const major = buf[6];
  const hlen = major === 1 ? buf.readUInt16LE(8) : buf.readUInt32LE(8);
  const start = major === 1 ? 10 : 12;
  const header = buf.subarray(start, start + hlen).toString('latin1');
  const descrMatch = header.match(/'descr':\s*('([^']*)'|\[.*\])\s*,/);
  const shapeMatch = header.match(/'shape':\s*\(([^)]*)\)/);
  if (!descrMatch || !shapeMatch || /'fortran_order':\s*True/.test(header))
    throw new Error(`${path}: unsupported .npy header ${header.trim()}`);
  const descr = descrMatch[2] !== undefined ? descrMatch[2] : descrMatch[1];
  const shape = shapeMatch[1].split(',').map((s) => s.trim()).filter((s) => s.length).map(Number);
  const count = shape.reduce((a, b) => a * b, 1);
  const body = buf.subarray(start + hlen);
  const T = TYPES[descr];
  if (!T) return {descr, shape, data: new Uint8Array(body.buffer, body.byteOffset, body.length)};
  if (body.length < count * T.BYTES_PER_ELEMENT) throw new Error(`${path}: truncated (${body.length} bytes)`);
  const copy = new Uint8Array(count * T.BYTES_PER_ELEMENT);
  copy.set(body.subarray(0, copy.length));
  return {descr, shape, data: new T(copy.buffer)};
}

/** The little-endian words of a .npy file's data (plain or structured records) as a Uint32Array (a copy). */
export function npyWords(path) {
  return wordsOf(readNpy(path).data);
}

/** The bytes of a typed array's elements as words (a copy, so the words are aligned whatever the file's header). */
export function wordsOf(data) {
  const b = new Uint8Array(data.buffer, data.byteOffset, data.byteLength).slice();
  return new Uint32Array(b.buffer, 0, b.byteLength >> 2);
}

/** Writes a .npy file: a plain typed array with the given shape (default: 1-D), or, with descr (a structured dtype's
 * list text as readNpy returns it, e.g. "[('t', '<f4'), ('id', '<u4')]"), the raw bytes of the records. */
export function writeNpy(path, data, shape = [data.length], descr = null) {
  if (!descr) descr = Object.keys(TYPES).find((k) => k !== '|u1' && TYPES[k] === data.constructor);
  if (!descr) throw new Error(`writeNpy: unsupported array type ${data.constructor.name}`);
  const descrText = descr.startsWith('[') ? descr : `'${descr}'`;
  const shapeText = shape.length === 1 ? `(${shape[0]},)` : `(${shape.join(', ')})`;
  let header = `{'descr': ${descrText}, 'fortran_order': False, 'shape': ${shapeText}, }`;
  const pad = 64 - ((10 + header.length + 1) % 64);
  header += ' '.repeat(pad % 64) + '\n';
  const head = Buffer.alloc(10);
  MAGIC.copy(head, 0);
  head[6] = 1;
  head[7] = 0;
  head.writeUInt16LE(header.length, 8);
  fs.writeFileSync(path, Buffer.concat([head, Buffer.from(header, 'latin1'),
    Buffer.from(data.buffer, data.byteOffset, data.byteLength)]));
}
