// What failing cases have in common, so a user need not bisect the matrix by hand: per family, the size rule that
// separates failing from passing cases (n % m != 0, above or below a size), the distributions that alone fail, and
// the first bad check when every failure shares it ("fails only when n % 256 != 0; first bad check always
// check-sort pass: radix pass # (digit bits #..#) is the first to diverge").

/** A diagnosis with its numbers as '#': failures that differ only in indices and values read alike. */
const shape = (s) => String(s || '').replace(/0x[0-9a-fA-F]+|\d+(\.\d+)?(e[-+]?\d+)?/g, '#');

/** Rows of gpu/run's summary (case, family, params {size, dist}, pass, check, fault, diagnosis): one sentence per
 * family with failures and passes to contrast, or with failures alone; [] when nothing fails. */
export function patterns(rows) {
  const out = [];
  const families = [...new Set(rows.map((r) => r.family))];
  for (const fam of families) {
    const all = rows.filter((r) => r.family === fam);
    const bad = all.filter((r) => !r.pass), good = all.filter((r) => r.pass);
    if (!bad.length || (bad.length < 2 && good.length)) continue; // one failure is its own diagnosis
    const parts = [];
    const size = (r) => (r.params || {}).size;
    const sized = all.every((r) => Number.isInteger(size(r)));
    if (!good.length) parts.push(`every case fails (${bad.length})`);
    else if (sized) {
      let mod = 0;
      for (let m = 2; m <= 1 << 20; m *= 2)
        if (bad.every((r) => size(r) % m !== 0) && good.every((r) => size(r) % m === 0)) mod = m;
      const maxGood = Math.max(...good.map(size)), minGood = Math.min(...good.map(size));
      const minBad = Math.min(...bad.map(size)), maxBad = Math.max(...bad.map(size));
      if (mod) parts.push(`fails only when n % ${mod} != 0`);
      else if (minBad > maxGood) parts.push(`fails only above n = ${maxGood} (from n = ${minBad})`);
      else if (maxBad < minGood) parts.push(`fails only below n = ${minGood} (up to n = ${maxBad})`);
    }
    const dist = (r) => (r.params || {}).dist;
    if (good.length && bad.every((r) => dist(r))) {
      const badDists = [...new Set(bad.map(dist))];
      if (badDists.every((d) => !good.some((r) => dist(r) === d)) && badDists.length < new Set(all.map(dist)).size)
        parts.push(`fails only for ${badDists.join(', ')}`);
    }
    const checks = new Set(bad.map((r) => `${r.check}${r.fault ? ` ${r.fault}` : ''}`));
    if (checks.size === 1) {
      const shapes = new Set(bad.map((r) => shape(r.diagnosis)));
      parts.push(`first bad check always ${[...checks][0]}` + (shapes.size === 1 && bad[0].diagnosis
        ? `: ${[...shapes][0].slice(0, 160)}` : ''));
    }
    if (parts.length) out.push(`${fam}: ${bad.length} of ${all.length} cases fail; ${parts.join('; ')}`);
  }
  return out;
}
