// Per-kernel GPU time through timestamp-query: every compute pass a kernel family begins through a Timer gets
// timestampWrites when the device has the feature; collect() sums nanoseconds per label.
const SLOTS = 4096; // queries per set: two per pass

export class Timer {
  /** enabled: whether to measure (--timestamps); a device without 'timestamp-query' measures nothing. */
  constructor(device, enabled) {
    this.device = device;
    this.on = Boolean(enabled) && Boolean(device) && device.features.has('timestamp-query');
    this.sets = [];
    this.labels = [];
    this.totals = new Map(); // label -> {ns, passes}
    this.quantum = 0n; // the gcd of every raw timestamp read: the timer's effective resolution
  }

  /** enc.beginComputePass(), with timestamp writes attributed to `label` while measuring. */
  pass(enc, label) {
    if (!this.on) return enc.beginComputePass({label});
    return enc.beginComputePass({label, timestampWrites: this.writes(label)});
  }

  /** The timestampWrites of a pass (compute or render) attributed to `label`; only while measuring. */
  writes(label) {
    const slot = this.labels.length % (SLOTS / 2);
    if (slot === 0) this.sets.push({set: this.device.createQuerySet({type: 'timestamp', count: SLOTS}), labels: []});
    const cur = this.sets[this.sets.length - 1];
    cur.labels.push(label);
    this.labels.push(label);
    return {querySet: cur.set, beginningOfPassWriteIndex: 2 * slot, endOfPassWriteIndex: 2 * slot + 1};
  }

  /** Resolves every pending query (after the passes' work was submitted) into the per-label totals. */
  async collect() {
    if (!this.on || !this.sets.length) return;
    const {readBack} = await import('./gpu.js');
    const enc = this.device.createCommandEncoder();
    const bufs = this.sets.map(({set, labels}) => {
      const b = this.device.createBuffer({size: 16 * labels.length,
        usage: GPUBufferUsage.QUERY_RESOLVE | GPUBufferUsage.COPY_SRC});
      enc.resolveQuerySet(set, 0, 2 * labels.length, b, 0);
      return b;
    });
    const outs = await readBack(this.device, enc, bufs, bufs.map((b) => b.size));
    this.sets.forEach(({set, labels}, s) => {
      const t = new BigUint64Array(outs[s]);
      const gcd = (a, b) => (b ? gcd(b, a % b) : a);
      for (let k = 0; k < 2 * labels.length; k++) if (t[k]) this.quantum = gcd(t[k], this.quantum);
      labels.forEach((label, i) => {
        const ns = t[2 * i + 1] > t[2 * i] ? Number(t[2 * i + 1] - t[2 * i]) : 0;
        const cur = this.totals.get(label) || {ns: 0, passes: 0};
        cur.ns += ns;
        cur.passes++;
        this.totals.set(label, cur);
      });
      set.destroy();
      bufs[s].destroy();
    });
    this.sets = [];
    this.labels = [];
  }

  /** The timestamps' resolution in ns as the values show it (the gcd of all read, up to 2^20 ns), or null before any:
   * Dawn quantizes timestamps (to 65,536 ns) unless its timestamp_quantization toggle is off, as openDevice asks. */
  quantumNs() {
    if (!this.quantum) return null;
    return Number(this.quantum > 1n << 20n ? 1n << 20n : this.quantum);
  }

  /** {label: {ms, passes}} of everything collected so far, and resets. */
  take() {
    const out = {};
    for (const [label, {ns, passes}] of this.totals) out[label] = {ms: ns / 1e6, passes};
    this.totals = new Map();
    return out;
  }
}
