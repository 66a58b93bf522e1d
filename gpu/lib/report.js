// The runner's static HTML page: one row per case with the oracle's diagnosis, and for frames the expected, actual
// and diff images side by side (copied next to the page, so it survives the run's temporary directory).
import fs from 'node:fs';
import path from 'node:path';

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'})[c]);

export function writeHtml(file, summary) {
  const assets = file.replace(/\.html?$/, '') + '_files';
  fs.rmSync(assets, {recursive: true, force: true});
  let copied = 0;
  const image = (src, name) => {
    if (!src || !fs.existsSync(src)) return '<td class="none">—</td>';
    fs.mkdirSync(assets, {recursive: true});
    const dst = path.join(assets, `${copied++}_${name}`);
    fs.copyFileSync(src, dst);
    const rel = path.relative(path.dirname(path.resolve(file)), dst);
    return `<td><a href="${esc(rel)}"><img src="${esc(rel)}" alt="${esc(name)}"></a></td>`;
  };
  const rows = summary.results.map((r) => {
    const times = Object.entries(r.gpu_ms || {}).map(([k, v]) => `${esc(k)} ${(v.ms / r.repeat).toFixed(3)} ms`)
      .join('<br>');
    const imgs = r.images ? image(r.images.expected, 'expected.png') + image(r.images.actual, 'actual.png') +
      image(r.images.diff, 'diff.png') : '<td></td><td></td><td></td>';
    const shrunk = r.shrunk ? `<br><b>smallest failing:</b> ${esc(r.shrunk.id)} ${esc(r.shrunk.diagnosis ||
      r.shrunk.note || '')}` : '';
    return `<tr class="${r.pass ? 'pass' : r.passes ? 'flaky' : 'fail'}"><td>${esc(r.case)}</td>` +
      `<td>${r.pass ? 'pass' : 'FAIL'} ${r.passes}/${r.repeat}</td><td>${esc(r.check || '')}</td>` +
      `<td>${esc(r.diagnosis)}${shrunk}</td><td>${times}</td>${imgs}</tr>`;
  }).join('\n');
  const html = `<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>rtoracle GPU run: ${esc(summary.backend)}</title>
<style>
body { font: 14px sans-serif; margin: 1em; } table { border-collapse: collapse; }
td, th { border: 1px solid #ccc; padding: 3px 6px; vertical-align: top; text-align: left; }
tr.pass td:nth-child(2) { color: #070; } tr.fail td:nth-child(2) { color: #b00; font-weight: bold; }
tr.flaky td:nth-child(2) { color: #c60; font-weight: bold; } p.warning { color: #c60; } img { width: 128px; image-rendering: pixelated; }
</style></head><body>
<h1>rtoracle GPU run</h1>
<p>Device: ${esc(summary.backend)} ${esc(summary.adapter || '')}. ${summary.cases - summary.failed} of
${summary.cases} cases pass${summary.flaky ? `, ${summary.flaky} flaky` : ''}; every case run ${summary.repeat}
time(s)${summary.timestamps ? '; GPU times per run from timestamp-query' : ''}.</p>
<p>Kernels: ${summary.user_kernels && summary.user_kernels.length ? `yours: ${summary.user_kernels.map(esc).join(', ')};
the rest bundled` : 'all bundled'}.</p>
${(summary.warnings || []).map((w) => `<p class="warning"><b>Warning:</b> ${esc(w)}</p>`).join('\n')}
${(summary.patterns || []).map((w) => `<p><b>Pattern:</b> ${esc(w)}</p>`).join('\n')}
<table><tr><th>case</th><th>result</th><th>check</th><th>oracle's diagnosis</th><th>GPU time per kernel</th>
<th>expected</th><th>actual</th><th>diff</th></tr>
${rows}
</table></body></html>
`;
  fs.writeFileSync(file, html);
}
