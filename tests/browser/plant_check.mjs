// The plant archive's pages in a real browser: `imuqual serve` on PostgreSQL.
//
// GIVEN a throwaway PostgreSQL cluster (scripts/pg-throwaway) and three
//       station archives shipped to it with `imuqual sync`: station st-1
//       soaks units 1-2 of lot PB and unit 1 of lot PC, station st-2 units
//       3-4 of PB (one lot across two stations) and unit PB-U01 again (a
//       unit retested on another station); a production history (6 lots of
//       12 units on four stations, drifting) with a golden-unit study (6
//       units, 3 soaks on each of 3 stations, station-3 reading noise 20 %
//       high) from imuqual-history-gen,
// WHEN  `imuqual serve --db postgresql://...` serves the plant on a loopback
//       port and headless Chromium opens the lots page, the split lot's
//       page, the retested unit's history, a control chart, the MSA page and
//       the yields page,
// THEN  every page loads with no console error, no page error and no
//       request outside the server; the split lot's page lists its four
//       units from both stations; the unit's history shows both runs, one
//       per station, linked to run pages that open; the control chart's
//       table equals `imuqual chart --format csv` on the plant, subgroup for
//       subgroup, value for value; the MSA page names station-3 out of
//       agreement at the top and its offsets table equals `imuqual msa
//       --format csv`; the yields page equals `imuqual yields --format csv`.
//
// Usage: node plant_check.mjs --imuqual BIN [--chromium PATH]
// Exit status 0 when every check passes, 1 otherwise (each failure is one
// line on stderr).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { fail, finish, launch, parseArgs, run, serve, waitFor, watchedPage } from './check_lib.mjs';

const kRepo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const kPgThrowaway = path.join(kRepo, 'scripts', 'pg-throwaway');

// CSV text (quoted fields, doubled quotes) -> { head, rows }.
function parseCsv(text) {
  const records = [];
  let field = '';
  let record = [];
  let quoted = false;
  for (let i = 0; i < text.length; ++i) {
    const c = text[i];
    if (quoted) {
      if (c === '"' && text[i + 1] === '"') { field += '"'; ++i; } else if (c === '"') quoted = false;
      else field += c;
    } else if (c === '"') quoted = true;
    else if (c === ',') { record.push(field); field = ''; }
    else if (c === '\n') { record.push(field); records.push(record); record = []; field = ''; }
    else field += c;
  }
  if (field !== '' || record.length > 0) { record.push(field); records.push(record); }
  const [head, ...rows] = records;
  return { head, rows };
}

// The page's first table.data (or the one after heading `after`) as
// { head, rows }: each cell its exact value (data-v) where it has one,
// else its text.
async function pageTable(page, after = null) {
  return page.evaluate((afterText) => {
    let table = document.querySelector('table.data');
    if (afterText) {
      const h = [...document.querySelectorAll('h2')].find((e) => e.textContent === afterText);
      table = null;
      for (let e = h?.nextElementSibling; e; e = e.nextElementSibling) {
        if (e.matches('table.data')) { table = e; break; }
        if (e.querySelector) { const t = e.querySelector('table.data'); if (t) { table = t; break; } }
      }
    }
    if (!table) return null;
    const head = [...table.querySelectorAll('thead th')].map((th) => th.textContent);
    const rows = [...table.querySelectorAll('tbody tr')].map((tr) => [...tr.cells].map(
        (td) => td.getAttribute('data-v') ?? td.textContent));
    return { head, rows };
  }, after);
}

// Equal tables: the same columns, and each cell equal as a number where
// both read as one (the page's data-v is the exact value), else as text.
function sameTable(what, shown, printed) {
  if (!shown) { fail(`${what}: no table on the page`); return; }
  if (JSON.stringify(shown.head) !== JSON.stringify(printed.head)) {
    fail(`${what}: columns ${JSON.stringify(shown.head)} on the page, ${JSON.stringify(printed.head)} printed`);
    return;
  }
  if (shown.rows.length !== printed.rows.length) {
    fail(`${what}: ${shown.rows.length} rows on the page, ${printed.rows.length} printed`);
    return;
  }
  let cells = 0;
  shown.rows.forEach((row, r) => row.forEach((cell, c) => {
    const want = printed.rows[r][c];
    const a = Number(cell);
    const b = Number(want);
    const equal = cell === want || (cell !== '' && want !== '' && !Number.isNaN(a) && a === b);
    if (!equal) fail(`${what}: row ${r + 1} ${shown.head[c]}: '${cell}' on the page, '${want}' printed`);
    ++cells;
  }));
  return cells;
}

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const started = Date.now();
  const work = fs.mkdtempSync(path.join(os.tmpdir(), 'imuqual-plant-'));
  fs.chmodSync(work, 0o755);
  const cluster = path.join(work, 'cluster');
  const imuqual = (a) => run(args.imuqual, a);
  const historyGen = path.join(path.dirname(args.imuqual), 'imuqual-history-gen');
  let child = null;
  let context = null;
  let chartCells = 0;
  try {
    const admin = run(kPgThrowaway, ['start', cluster]).trim();
    const plant = admin;
    // The stations.
    const soak = (db, station, lot, serials, first) => {
      const units = [];
      serials.forEach((s, i) => units.push('--unit', `${s}=sim:vg700,index=${first + i}`));
      imuqual(['run', '--quiet', ...units, '--duration', '4000', '--rate', '50', '--plan',
               'builtin:vg700ca', '--lot', lot, '--db', db, '--station-id', station]);
    };
    const st1 = path.join(work, 'st-1.db');
    const st2 = path.join(work, 'st-2.db');
    const history = path.join(work, 'history.db');
    soak(st1, 'st-1', 'PB', ['PB-U01', 'PB-U02'], 0);
    soak(st1, 'st-1', 'PC', ['PC-U01'], 0);
    soak(st2, 'st-2', 'PB', ['PB-U03', 'PB-U04'], 2);
    soak(st2, 'st-2', 'PB', ['PB-U01'], 0);
    run(historyGen, ['--db', history, '--lots', '6', '--units', '12', '--prefix', 'H', '--drift', '0.05']);
    run(historyGen, ['--db', history, '--lots', '0', '--units', '6', '--golden-stations', '3',
                     '--golden-trials', '3', '--station-gain', 'station-3=1.2', '--prefix', 'G']);
    for (const db of [st1, st2, history]) imuqual(['sync', '--quiet', '--db', db, '--to', plant]);

    const served = await serve(args.imuqual, ['--db', plant]);
    child = served.child;
    const base = served.url;
    const origin = new URL(base).origin;
    context = await launch(args, work);
    const page = await watchedPage(context, origin);
    const visit = async (url) => {
      const response = await page.goto(url, { waitUntil: 'load', timeout: 30000 });
      if (!response || response.status() !== 200) fail(`${url}: status ${response?.status()}`);
    };

    // The lots page lists the split lot once.
    await visit(base);
    const lots = await pageTable(page);
    const pb = lots?.rows.filter((r) => r[0] === 'PB') ?? [];
    if (pb.length !== 1) fail(`the lots page lists lot PB ${pb.length} times`);

    // The split lot: four units, from both stations.
    await visit(`${base}lot/PB`);
    const lotText = await page.evaluate(() => document.body.innerText);
    for (const s of ['PB-U01', 'PB-U02', 'PB-U03', 'PB-U04']) {
      if (!lotText.includes(s)) fail(`the lot page of PB does not show ${s}`);
    }
    for (const st of ['st-1', 'st-2']) {
      if (!lotText.includes(st)) fail(`the lot page of PB does not name station ${st}`);
    }
    await waitFor(page, 'the lot noise model and plots of PB', 30,
                  () => document.querySelector('#lot-model table.lot-model') !== null &&
                        document.querySelectorAll('#lot-plots figure svg').length > 0);

    // The retested unit: one run per station, each run page opens.
    await visit(`${base}unit/PB-U01`);
    const unit = await pageTable(page);
    const stationCol = unit?.head.indexOf('station') ?? -1;
    if (!unit || unit.rows.length !== 2) {
      fail(`unit PB-U01: ${unit?.rows.length} runs shown, 2 expected`);
    } else if (stationCol < 0) {
      fail('unit PB-U01: no station column');
    } else {
      const stations = unit.rows.map((r) => r[stationCol]).sort();
      if (JSON.stringify(stations) !== '["st-1","st-2"]') fail(`unit PB-U01: stations ${stations}`);
      const links = await page.evaluate(() => [...document.querySelectorAll('table.data tbody a')]
          .map((a) => a.getAttribute('href')).filter((h) => h.includes('run')));
      if (links.length !== 2) fail(`unit PB-U01: ${links.length} run links`);
      for (const l of links) {
        await visit(new URL(l, base).href);
        const title = await page.title();
        if (!title.includes('PB-U01')) fail(`run page ${l}: title '${title}'`);
      }
    }

    // A control chart, against the command line.
    const chartArgs = ['--measurement', 'bias_instability', '--axis', 'gx', '--by', 'lot'];
    await visit(`${base}chart?measurement=bias_instability&axis=gx&by=lot`);
    chartCells = sameTable('control chart', await pageTable(page),
                                 parseCsv(imuqual(['chart', '--db', plant, ...chartArgs, '--format', 'csv'])));
    // The chart drawn: a point per subgroup, the flagged ones those with rules.
    const drawn = await page.evaluate(() => {
      const circles = [...document.querySelectorAll('figure svg circle[data-subgroup]')];
      const head = [...document.querySelectorAll('table.data thead th')].map((th) => th.textContent);
      const rules = head.indexOf('rules');
      const rows = [...document.querySelectorAll('table.data tbody tr')];
      return {
        points: circles.map((c) => c.getAttribute('data-subgroup')),
        flagged: circles.filter((c) => c.getAttribute('data-flagged') === 'true').map((c) => c.getAttribute('data-subgroup')),
        subgroups: rows.map((tr) => tr.cells[0].textContent),
        withRules: rows.filter((tr) => tr.cells[rules].textContent.trim() !== '').map((tr) => tr.cells[0].textContent),
      };
    });
    if (JSON.stringify(drawn.points) !== JSON.stringify(drawn.subgroups)) {
      fail(`control chart: points ${JSON.stringify(drawn.points)} drawn, subgroups ${JSON.stringify(drawn.subgroups)}`);
    }
    if (JSON.stringify(drawn.flagged) !== JSON.stringify(drawn.withRules)) {
      fail(`control chart: ${JSON.stringify(drawn.flagged)} ringed, ${JSON.stringify(drawn.withRules)} flagged by a rule`);
    }
    const chartSummary = await page.evaluate(() => document.body.innerText);
    if (!/subgroups flagged/.test(chartSummary)) fail('the control chart page says nothing of flagged subgroups');

    // MSA: station-3 named at the top; the offsets as the command prints them.
    const msaQuery = 'lot=G-GOLDEN&measurement=bias_instability&axis=gx';
    await visit(`${base}msa?${msaQuery}`);
    const alert = await page.evaluate(() => document.querySelector('main .alert, .alert')?.textContent ?? '');
    if (!alert.includes('station-3')) fail(`the MSA page does not name station-3 out of agreement: '${alert}'`);
    // Exit 3: a station out of agreement (what is expected here).
    const msa = spawnSync(args.imuqual, ['msa', '--db', plant, '--lot', 'G-GOLDEN', '--measurement',
                                         'bias_instability', '--axis', 'gx', '--format', 'csv'],
                          { encoding: 'utf8' });
    if (msa.status !== 3) fail(`imuqual msa exited ${msa.status}, not 3 (a station differs): ${msa.stderr}`);
    const msaPrinted = msa.stdout ?? '';
    const blank = msaPrinted.indexOf('\n\n');
    if (blank < 0) {
      fail(`imuqual msa printed no offsets table: ${msaPrinted.slice(0, 200)}`);
    } else {
      sameTable('MSA studies', await pageTable(page, 'Studies'), parseCsv(msaPrinted.slice(0, blank + 1)));
      sameTable('MSA offsets', await pageTable(page, 'Each station against the fleet'),
                parseCsv(msaPrinted.slice(blank + 2)));
    }

    // Yields by station.
    await visit(`${base}yields?by=station`);
    sameTable('yields by station', await pageTable(page),
              parseCsv(imuqual(['yields', '--db', plant, '--by', 'station', '--format', 'csv'])));

  } finally {
    if (context) await context.close();
    child?.kill('SIGTERM');
    try { run(kPgThrowaway, ['stop', cluster]); } catch (e) { fail(`stopping the cluster: ${e.message}`); }
  }
  const seconds = ((Date.now() - started) / 1000).toFixed(1);
  finish('plant_check', `the plant on PostgreSQL: lots, a lot across two stations, a unit across ` +
         `two stations, control chart (${chartCells} cells), MSA and yields against the command ` +
         `line, no console error, no outside request (${seconds} s)`,
         work, () => fs.rmSync(work, { recursive: true, force: true }));
}

main().catch((e) => {
  console.error(`plant_check: FAIL: ${e.message}`);
  process.exit(1);
});
