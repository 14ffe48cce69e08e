// The HTML lot report in a real browser, checked against the archive.
//
// GIVEN a small real archive (8 simulated VG700-like gyros, 20 min each; the
//       8th unit of the lot is planted to fail on bias instability) judged
//       by the built-in VG700 plan renamed with HTML in its name and
//       description,
// WHEN  `imuqual report` writes the lot's HTML and headless Chromium opens it,
// THEN  the page renders with no console error, no page error and no request
//       other than the file itself (and data: URLs); every per-unit value and
//       verdict equals `imuqual lot --format json`; every statistic equals
//       what the archive's measurements give (recomputed here from sqlite3);
//       the header equals the lot_overview view; the failing and marginal
//       units are listed with their reasons and plotted; the visible text is
//       the value rounded to 4 significant digits (with its ± u: to u's second
//       significant digit); the plan's HTML shows as
//       text; the tables sort on click.
//
// Usage: node report_check.mjs --imuqual BIN [--chromium PATH]
//        node report_check.mjs --imuqual BIN --db FILE --html FILE --lot LOT
//          (checks an existing report against its archive; nothing generated)
// Exit status 0 when every check passes, 1 otherwise (each failure is one
// line on stderr).
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { chromium } from 'playwright-core';
import { fail, failures, run, sqlite, sqlText } from './check_lib.mjs';

// Mean, sd and capability are recomputed here in double precision from the
// same values; the summation order may differ from imuqual's, which moves the
// last bits only: 1e-12 relative is ~4500 ulp, far below any real mismatch
// (a wrong value, unit or population) and far above rounding.
const kRecomputedRelTol = 1e-12;
const kLot = 'RPT';
const kUnits = 8;
const kDurationS = 4000;  // past the plan's minimum duration: verdicts come from the noise
// The built-in VG700 plan under a name and description that are HTML: the
// page must show them as text (every text from the archive is escaped).
const kPlanSource = new URL('../../plans/vg700ca.textproto', import.meta.url);
const kPlanName = 'vg700ca-eol <b>"bold"</b> & \'quoted\'';
const kPlanDescription = '</small><script>window.injected = 1</script><img src="x.png"> & more';

function parseArgs(argv) {
  const args = { chromium: '/usr/bin/chromium' };
  for (let i = 0; i < argv.length; i += 2) {
    const key = argv[i].replace(/^--/, '');
    if (!['imuqual', 'chromium', 'db', 'html', 'lot'].includes(key) || i + 1 >= argv.length) {
      throw new Error(`unknown or incomplete argument '${argv[i]}'`);
    }
    args[key] = argv[i + 1];
  }
  if (!args.imuqual) throw new Error('--imuqual BIN is required');
  if ((args.db !== undefined) !== (args.html !== undefined)) {
    throw new Error('--db and --html go together');
  }
  return args;
}

// Exact equality of a page value (data-v text) with an archive value (number
// or null): the page writes the shortest text that parses back to the same double.
function sameExact(pageText, dbValue) {
  if (dbValue === null || dbValue === undefined || Number.isNaN(dbValue)) return pageText === '';
  return pageText !== '' && Number(pageText) === dbValue;
}

function sameClose(pageText, expected) {
  if (expected === null || !Number.isFinite(expected)) return pageText === '';
  if (pageText === '') return false;
  const v = Number(pageText);
  return Math.abs(v - expected) <= kRecomputedRelTol * Math.max(Math.abs(expected), 1e-300);
}

// The visible text of a number cell is the value to 4 significant digits:
// "12.42", "−3.5", "1.234×10−5" (en dash for none). Shown with its
// uncertainty u (> 0), it is quoted as a measurement is: to the decimal
// place of u's second significant digit ("410 ± 280", "10.20 ± 0.81").
function visibleMatches(text, exact, u = NaN) {
  const t = text.trim();
  if (exact === '') return t === '\u2013';
  const v = Number(exact);
  const m = /^(\u2212?)(\d+(?:\.\d+)?)(?:\u00d710(\u2212?)(\d+))?$/.exec(t);
  if (!m) return false;
  let shown = Number(m[2]) * (m[3] !== undefined ? 10 ** ((m[3] ? -1 : 1) * Number(m[4])) : 1);
  if (m[1]) shown = -shown;
  if (Number.isFinite(u) && u > 0) {
    let place = Math.floor(Math.log10(u)) - 1;
    if (Math.round(u / 10 ** place) >= 100) place += 1;  // u rounded up to a new decade
    // Exactly the value rounded to that place (a tie either way).
    const step = 10 ** place, q = v / step;
    const tie = Math.abs(Math.abs(q - Math.trunc(q)) - 0.5) < 1e-9;
    return tie ? Math.abs(shown - v) <= 0.5 * step * (1 + 1e-9)
               : Math.abs(shown - Math.round(q) * step) <= 1e-6 * step;
  }
  const digits = m[2].replace('.', '').replace(/^0+/, '');
  if (digits.length > 4) return false;
  if (v === 0) return shown === 0;
  const halfStep = 0.5 * 10 ** (Math.floor(Math.log10(Math.abs(v))) - 3);
  return Math.abs(shown - v) <= halfStep * (1 + 1e-9);
}

// judge::Summarize, recomputed: n, mean, sample sd, min, max, yield over
// PASS, MARGINAL and FAIL values, capability against the limits.
function summarize(group) {
  const values = group.values.filter((v) => v !== null && Number.isFinite(v));
  const s = { n: values.length, mean: null, sd: null, min: null, max: null, yield: null,
              capability: null, kind: '' };
  // An INCONCLUSIVE value is neither a pass nor a loss.
  const judged = group.outcomes.filter((o) => o === 'PASS' || o === 'MARGINAL' || o === 'FAIL');
  if (judged.length > 0) {
    s.yield = judged.filter((o) => o === 'PASS' || o === 'MARGINAL').length / judged.length;
  }
  if (s.n === 0) return s;
  s.mean = values.reduce((a, b) => a + b, 0) / s.n;
  s.min = Math.min(...values);
  s.max = Math.max(...values);
  if (s.n >= 2) {
    s.sd = Math.sqrt(values.reduce((a, v) => a + (v - s.mean) ** 2, 0) / (s.n - 1));
  }
  // The index the limits call for; its value only from 10 values on
  // (judge::kMinCapabilityN), with Bissell's 95 % interval.
  s.kind = group.high !== null && group.low !== null ? 'Cpk'
         : group.high !== null ? 'Cpu' : group.low !== null ? 'Cpl' : '';
  if (s.sd !== null && s.sd > 0 && s.n >= 10) {
    const upper = group.high !== null ? (group.high - s.mean) / (3 * s.sd) : null;
    const lower = group.low !== null ? (s.mean - group.low) / (3 * s.sd) : null;
    if (upper !== null && lower !== null) s.capability = Math.min(upper, lower);
    else if (upper !== null) s.capability = upper;
    else if (lower !== null) s.capability = lower;
    if (s.capability !== null) {
      const half = 1.959963984540054 *
                   Math.sqrt(1 / (9 * s.n) + s.capability ** 2 / (2 * (s.n - 1)));
      [s.capabilityLow, s.capabilityHigh] = [s.capability - half, s.capability + half];
    }
  }
  return s;
}

async function renderAndRead(htmlPath, chromiumPath, profileDir) {
  const context = await chromium.launchPersistentContext(profileDir, {
    executablePath: chromiumPath,
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
           '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    timeout: 60000,
  });
  try {
    const page = context.pages()[0] || await context.newPage();
    const problems = [];
    const url = pathToFileURL(htmlPath).href;
    page.on('console', (msg) => {
      if (msg.type() === 'error' || msg.type() === 'warning') {
        problems.push(`console ${msg.type()}: ${msg.text()}`);
      }
    });
    page.on('pageerror', (err) => problems.push(`page error: ${err.message}`));
    page.on('requestfailed', (req) => {
      problems.push(`failed request: ${req.url()} (${req.failure()?.errorText})`);
    });
    page.on('request', (req) => {
      if (req.url() !== url && !req.url().startsWith('data:')) {
        problems.push(`request for another resource: ${req.url()}`);
      }
    });
    const response = await page.goto(url, { waitUntil: 'load', timeout: 30000 });
    if (!response || !response.ok()) problems.push(`loading ${url} failed`);

    const dom = await page.evaluate(() => {
      const cells = (row, attr) => {
        const out = {};
        for (const td of row.querySelectorAll(`td[${attr}]`)) {
          out[td.getAttribute(attr)] = {
            // The number's own element when the cell carries marks (≤, †, ‡, ± u) beside it.
            v: td.getAttribute('data-v'), text: (td.querySelector('.v') ?? td).textContent,
            outcome: td.getAttribute('data-outcome'), u: td.getAttribute('data-u'),
            q: td.getAttribute('data-q'), whole: td.textContent,
            kind: td.getAttribute('data-kind'), sort: td.getAttribute('data-sort'),
            lo: td.getAttribute('data-lo'), hi: td.getAttribute('data-hi'),
          };
        }
        return out;
      };
      const facts = {};
      for (const el of document.querySelectorAll('[data-field]')) {
        if (el.closest('tr')) continue;
        facts[el.getAttribute('data-field')] = { v: el.getAttribute('data-v'), text: el.textContent };
      }
      return {
        title: document.title,
        facts,
        results: [...document.querySelectorAll('table.results tbody tr')].map((tr) => ({
          run: tr.dataset.run, unit: tr.dataset.serial, axis: tr.dataset.axis,
          m: cells(tr, 'data-m'), field: cells(tr, 'data-field'),
        })),
        stats: [...document.querySelectorAll('table.stats tbody tr')].map((tr) => ({
          axis: tr.dataset.axis, name: tr.dataset.name, unit: tr.dataset.unit,
          s: cells(tr, 'data-stat'),
        })),
        attention: [...document.querySelectorAll('#attention ul.reasons > li')].map((li) => ({
          unit: li.dataset.serial, run: li.dataset.run, verdict: li.dataset.verdict,
          badge: li.querySelector('.badge')?.textContent.trim(),
          reasons: [...li.querySelectorAll('ul > li')].map((r) => r.textContent),
        })),
        lotPlots: [...document.querySelectorAll('#lot-plots figure')].map((f) => ({
          svg: !!f.querySelector('svg'), curves: f.querySelectorAll('svg polyline').length,
          caption: f.querySelector('figcaption')?.textContent || '',
          tooltips: [...f.querySelectorAll('svg g > title')].map((t) => t.textContent),
          boldColours: [...f.querySelectorAll('svg g > polyline')]
            .filter((l) => Number(l.getAttribute('stroke-width')) > 2).map((l) => l.getAttribute('stroke')),
        })),
        unitPlots: [...document.querySelectorAll('#unit-plots figure')].map((f) => ({
          id: f.id, run: f.dataset.run, svg: !!f.querySelector('svg'), curves: f.querySelectorAll('svg polyline').length,
          caption: f.querySelector('figcaption')?.textContent || '', series: f.dataset.plot === 'series',
          davar: f.dataset.plot === 'davar',
          // Every text of the plot inside its SVG's box (nothing cut off).
          textsOutside: [...f.querySelectorAll('svg text')].filter((t) => {
            const b = t.getBoundingClientRect(), s = t.ownerSVGElement.getBoundingClientRect();
            return b.width > 0 && (b.left < s.left - 0.5 || b.right > s.right + 0.5 ||
                                   b.top < s.top - 0.5 || b.bottom > s.bottom + 0.5);
          }).map((t) => t.textContent),
        })),
        scripts: document.scripts.length,
        images: document.images.length,
        injected: window.injected !== undefined,
        planText: document.querySelector('[data-field="plan"]')?.textContent || '',
        planValue: document.querySelector('[data-field="plan"]')?.getAttribute('data-v'),
        externalRefs: [...document.querySelectorAll('[src], link[href]')]
            .map((e) => e.getAttribute('src') || e.getAttribute('href'))
            .filter((u) => !u.startsWith('data:')),
      };
    });

    // Sorting: the results table by bias instability, ascending then descending.
    const header = page.locator('table.results').first().locator('thead th', { hasText: 'Bias instability' });
    const sortedValues = async () => page.evaluate(() => [
      ...document.querySelector('table.results').querySelectorAll('tbody tr')]
        .map((tr) => Number(tr.querySelector('td[data-m="bias_instability"]').getAttribute('data-v'))));
    await header.click();
    const ascending = await sortedValues();
    await header.click();
    const descending = await sortedValues();
    return { dom, problems, ascending, descending };
  } finally {
    await context.close();
  }
}

let work = '';  // the scratch directory, kept when a check fails

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const started = Date.now();
  work = fs.mkdtempSync(path.join(os.tmpdir(), 'imuqual-report-'));
  let db = args.db;
  let html = args.html;
  const lot = args.lot || kLot;
  if (!db) {
    db = path.join(work, 'lot.db');
    html = path.join(work, 'report.html');
    const plan = path.join(work, 'plan.textproto');
    const textproto = (v) => JSON.stringify(v);  // a JSON string is a valid textproto string here
    fs.writeFileSync(plan, fs.readFileSync(kPlanSource, 'utf8')
        .replace(/^name: .*$/m, `name: ${textproto(kPlanName)}`)
        .replace(/^description: .*$/m, `description: ${textproto(kPlanDescription)}`));
    run(args.imuqual, ['run', '--sim', String(kUnits), '--duration', String(kDurationS), '--lot', lot,
                       '--db', db, '--plan', plan, '--quiet']);
    run(args.imuqual, ['report', '--db', db, '--lot', lot, '-o', html]);
  }

  // The archive, through the project's CLI and plain sqlite3.
  const rows = JSON.parse(run(args.imuqual, ['lot', lot, '--db', db, '--format', 'json']));
  const overview = sqlite(db, `SELECT * FROM lot_overview WHERE lot = ${sqlText(lot)}`);
  const measurements = sqlite(db, `
SELECT l.serial AS unit, l.run_id, m.axis, m.name, m.value, m.unit, m.low, m.high, m.outcome,
       m.uncertainty, CASE WHEN m.qualifier IS NOT NULL THEN m.qualifier
                   WHEN m.value IS NULL THEN 'not_measurable' ELSE 'measured' END AS qualifier
FROM final_runs l
JOIN measurements m ON m.run_key = l.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis
WHERE l.lot = ${sqlText(lot)}
ORDER BY l.serial, COALESCE(ra.axis_index, -1), m.name`);
  const runs = sqlite(db, `SELECT run_id, serial, verdict, reasons FROM final_runs WHERE lot = ${sqlText(lot)}`);

  const { dom, problems, ascending, descending } =
      await renderAndRead(html, args.chromium, path.join(work, 'chromium-profile'));
  for (const p of problems) fail(p);
  for (const ref of dom.externalRefs) fail(`the page references an external resource: ${ref}`);

  // Text from the archive stays text.
  if (dom.scripts !== 1 || dom.images !== 0 || dom.injected) {
    fail(`archive text became markup: ${dom.scripts} scripts, ${dom.images} images, injected ${dom.injected}`);
  }
  if (!args.db) {
    if (dom.planValue !== kPlanName) fail(`plan name: page '${dom.planValue}', archive '${kPlanName}'`);
    if (!dom.planText.includes(kPlanName) || !dom.planText.includes(kPlanDescription)) {
      fail(`plan shown as '${dom.planText}', not as the plan's name and description`);
    }
  }

  // The scenario this test is about: a lot with a planted failure.
  if (!args.db) {
    if (rows.length !== kUnits * 3) fail(`expected ${kUnits * 3} unit axes, the archive has ${rows.length}`);
    if (!rows.some((r) => r.verdict === 'FAIL')) fail('the archive has no failing axis: the planted failure is missing');
  }

  // Header against lot_overview.
  if (overview.length !== 1) {
    fail(`lot_overview has ${overview.length} rows for ${lot}`);
  } else {
    const o = overview[0];
    const f = dom.facts;
    const checks = [['lot', f.lot?.v, lot], ['units', f.units?.v, String(o.units)],
                    ['runs', f.runs?.v, String(o.runs)], ['pass', f.pass?.v, String(o.pass)],
                    ['marginal', f.marginal?.v, String(o.marginal)], ['fail', f.fail?.v, String(o.fail)],
                    ['first_start', f.first_start?.v, String(o.first_start_utime)],
                    ['last_start', f.last_start?.v, String(o.last_start_utime)]];
    for (const [name, page, want] of checks) {
      if (page !== want) fail(`header ${name}: page '${page}', archive '${want}'`);
    }
    for (const name of ['units', 'runs', 'pass', 'marginal', 'fail']) {
      if (f[name] && f[name].text.trim() !== f[name].v) fail(`header ${name}: shows '${f[name].text}', data ${f[name].v}`);
    }
    if (!f.yield || !sameExact(f.yield.v, o.yield)) fail(`header yield: page '${f.yield?.v}', archive ${o.yield}`);
    const shownYield = Number((f.yield?.text || '').replace(/[%\s\u00a0]/g, ''));
    if (o.yield !== null && !(Math.abs(shownYield - 100 * o.yield) <= 0.05 + 1e-9)) {
      fail(`header yield: shows '${f.yield?.text}', archive ${o.yield}`);
    }
  }

  // Per unit and axis: every value exactly, every verdict, every outcome colour.
  const pageRows = new Map(dom.results.map((r) => [`${r.run}\u0000${r.axis}`, r]));
  if (dom.results.length !== rows.length) {
    fail(`results table has ${dom.results.length} rows, imuqual lot has ${rows.length}`);
  }
  const outcomeOf = new Map(measurements.map((m) => [`${m.run_id}\u0000${m.axis}\u0000${m.name}`, m.outcome]));
  const measurementOf = new Map(measurements.map((m) => [`${m.run_id}\u0000${m.axis}\u0000${m.name}`, m]));
  for (const r of rows) {
    const p = pageRows.get(`${r.run_id}\u0000${r.axis}`);
    if (!p) {
      fail(`no results row for ${r.serial} axis ${r.axis}`);
      continue;
    }
    const gyro = r.kind !== 'accel';
    const expect = {
      random_walk: gyro ? r.arw_deg_rt_hr : r.vrw_m_s_rt_hr,
      bias_instability: gyro ? r.bias_instability_deg_hr : r.bias_instability_ug,
      bias_instability_ieee: gyro ? r.bias_instability_ieee_deg_hr : r.bias_instability_ieee_ug,
      tau_min_s: r.tau_min_s,
      rate_random_walk: gyro ? r.rrw_deg_hr_rt_hr : r.rrw_ug_rt_hr,
      gap_samples: r.gap_samples,
    };
    const measurementName = {
      random_walk: gyro ? 'angle_random_walk' : 'velocity_random_walk',
      bias_instability: 'bias_instability', bias_instability_ieee: 'bias_instability_ieee',
      tau_min_s: 'tau_at_minimum', rate_random_walk: 'rate_random_walk',
    };
    for (const [key, want] of Object.entries(expect)) {
      const cell = p.m[key];
      if (!cell) {
        fail(`${r.serial} ${r.axis}: no ${key} cell`);
        continue;
      }
      if (!sameExact(cell.v, want)) fail(`${r.serial} ${r.axis} ${key}: page ${cell.v}, archive ${want}`);
      const notMeasurable = cell.q === 'not_measurable';
      const uShown = cell.whole.includes('\u00b1') ? Number(cell.u) : NaN;
      if (notMeasurable ? cell.text.trim() !== 'n/m' : !visibleMatches(cell.text, cell.v, uShown)) {
        fail(`${r.serial} ${r.axis} ${key}: visible '${cell.text}' is not ${cell.v} ` +
             (Number.isFinite(uShown) ? `quoted to its uncertainty ${cell.u}` : 'to 4 digits'));
      }
      if (measurementName[key]) {
        const outcome = outcomeOf.get(`${r.run_id}\u0000${r.axis}\u0000${measurementName[key]}`) ?? null;
        if ((cell.outcome || null) !== outcome) {
          fail(`${r.serial} ${r.axis} ${key}: page outcome ${cell.outcome}, archive ${outcome}`);
        }
        // The marks: the qualifier, the uncertainty exactly, and what is shown beside the number.
        const m = measurementOf.get(`${r.run_id}\u0000${r.axis}\u0000${measurementName[key]}`);
        if (m) {
          if (cell.q !== m.qualifier) fail(`${r.serial} ${r.axis} ${key}: page qualifier ${cell.q}, archive ${m.qualifier}`);
          if (!sameExact(cell.u ?? '', m.uncertainty)) fail(`${r.serial} ${r.axis} ${key}: page uncertainty ${cell.u}, archive ${m.uncertainty}`);
          const marks = { upper_bound: '\u2264', minimum_not_resolved: '\u2020', model_inadequate: '\u2021' };
          if (marks[m.qualifier] && cell.v !== '' && !cell.whole.includes(marks[m.qualifier])) {
            fail(`${r.serial} ${r.axis} ${key}: ${m.qualifier} shown without its mark: '${cell.whole}'`);
          }
          const showsU = cell.whole.includes('\u00b1');
          const wantsU = m.uncertainty !== null && cell.v !== '' && m.qualifier !== 'upper_bound' && !notMeasurable;
          if (showsU !== wantsU) fail(`${r.serial} ${r.axis} ${key}: '${cell.whole}' ${wantsU ? 'lacks' : 'shows'} ± u`);
          // u itself to two significant digits.
          const uText = showsU ? cell.whole.split('\u00b1')[1].replace(/\u00a0/g, ' ').trim() : '';
          if (showsU && m.uncertainty > 0 && !visibleMatches(uText, String(m.uncertainty), m.uncertainty)) {
            fail(`${r.serial} ${r.axis} ${key}: '± ${uText}' is not ${m.uncertainty} to two significant digits`);
          }
        }
      }
    }
    const axisVerdict = p.field.axis_verdict?.text.trim();
    const runVerdict = p.field.run_verdict?.text.trim();
    if (axisVerdict !== (r.verdict || 'not judged')) fail(`${r.serial} ${r.axis}: axis verdict '${axisVerdict}', archive '${r.verdict}'`);
    if (runVerdict !== (r.run_verdict || 'not judged')) fail(`${r.serial} ${r.axis}: unit verdict '${runVerdict}', archive '${r.run_verdict}'`);
  }

  // Statistics, recomputed from the measurements of each unit's final run
  // (not the parameters of each unit's own noise model, model_*: units with
  // different models have nothing in common to average; nor each unit's own
  // stationarity events, event_*).
  const groups = new Map();
  for (const m of measurements) {
    if (m.name.startsWith('model_') || m.name.startsWith('event_')) continue;
    const key = `${m.axis}\u0000${m.name}`;
    if (!groups.has(key)) groups.set(key, { axis: m.axis, name: m.name, unit: m.unit, values: [], outcomes: [], low: null, high: null });
    const g = groups.get(key);
    g.values.push(m.value);
    g.outcomes.push(m.outcome);
    if (g.low === null && m.low !== null) g.low = m.low;
    if (g.high === null && m.high !== null) g.high = m.high;
  }
  const pageStats = new Map(dom.stats.map((s) => [`${s.axis}\u0000${s.name}`, s]));
  if (dom.stats.length !== groups.size) fail(`statistics has ${dom.stats.length} rows, the archive gives ${groups.size}`);
  for (const [key, g] of groups) {
    const p = pageStats.get(key);
    const what = `statistics ${g.name} axis '${g.axis}'`;
    if (!p) {
      fail(`${what}: no row`);
      continue;
    }
    if (p.unit !== g.unit) fail(`${what}: unit '${p.unit}', archive '${g.unit}'`);
    const s = summarize(g);
    // Absent cells are allowed only for values that do not exist (e.g. the
    // limits and capability of a measurement without limits).
    const want = { n: s.n, mean: s.mean, sd: s.sd, min: s.min, max: s.max, low: g.low, high: g.high,
                   yield: s.yield, capability: s.capability };
    const recomputed = new Set(['mean', 'sd', 'capability']);
    for (const [stat, value] of Object.entries(want)) {
      const cell = p.s[stat];
      if (!cell) {
        if (value !== null) fail(`${what}: no ${stat} cell (archive ${value})`);
        continue;
      }
      const same = recomputed.has(stat) ? sameClose(cell.v, value) : sameExact(cell.v, value);
      if (!same) fail(`${what} ${stat}: page ${cell.v}, archive ${value}`);
      if (['mean', 'sd', 'min', 'max', 'low', 'high'].includes(stat) && !visibleMatches(cell.text, cell.v)) {
        fail(`${what} ${stat}: visible '${cell.text}' is not ${cell.v} to 4 digits`);
      }
    }
    if (p.s.capability && (p.s.capability.kind || '') !== s.kind) {
      fail(`${what}: capability kind '${p.s.capability.kind}', expected '${s.kind}'`);
    }
    if (p.s.capability && s.capability !== null &&
        !(sameClose(p.s.capability.lo, s.capabilityLow) &&
          sameClose(p.s.capability.hi, s.capabilityHigh))) {
      fail(`${what}: capability interval [${p.s.capability.lo}, ${p.s.capability.hi}], ` +
           `expected [${s.capabilityLow}, ${s.capabilityHigh}]`);
    }
  }

  // Units needing attention: exactly the FAIL, MARGINAL, INCONCLUSIVE,
  // ABORTED and ERROR units, and those whose record shows a stationarity
  // event (any axis's stationarity_events >= 1), with their reasons.
  const moved = new Set(measurements
    .filter((m) => m.name === 'stationarity_events' && Number(m.value) >= 1).map((m) => m.run_id));
  const flagged = runs.filter((r) =>
    ['FAIL', 'MARGINAL', 'INCONCLUSIVE', 'ABORTED', 'ERROR'].includes(r.verdict) || moved.has(r.run_id));
  const pageFlagged = new Map(dom.attention.map((a) => [a.run, a]));
  if (dom.attention.length !== flagged.length) fail(`${dom.attention.length} units listed as needing a look, the archive has ${flagged.length}`);
  for (const r of flagged) {
    const a = pageFlagged.get(r.run_id);
    if (!a) {
      fail(`${r.serial} (${r.verdict}) is not listed as needing a look`);
      continue;
    }
    if (a.verdict !== r.verdict || a.badge !== r.verdict) {
      fail(`${r.serial}: listed as ${a.verdict} (badge '${a.badge}'), archive ${r.verdict}`);
    }
    const reasons = (r.reasons || '').split('\n').filter((x) => x !== '');
    if (JSON.stringify(a.reasons) !== JSON.stringify(reasons)) {
      fail(`${r.serial}: reasons on the page ${JSON.stringify(a.reasons)}, archive ${JSON.stringify(reasons)}`);
    }
  }

  // Plots: a lot overlay per axis, one plot per failing or marginal unit.
  const axes = new Set(rows.map((r) => r.axis));
  if (dom.lotPlots.length !== axes.size) fail(`${dom.lotPlots.length} lot plots for ${axes.size} axes`);
  for (const p of dom.lotPlots) {
    if (!p.svg || p.curves < rows.length / axes.size) fail(`lot plot '${p.caption}' lacks curves (${p.curves})`);
    // Every unit's curve names it on hover; the bold (flagged) ones each in their own colour.
    const units = new Set(rows.map((r) => r.serial));
    for (const u of units) {
      if (!p.tooltips.some((t) => t.startsWith(`${u} `))) fail(`lot plot: no tooltip names unit ${u}`);
    }
    if (new Set(p.boldColours).size !== Math.min(p.boldColours.length, 6)) {
      fail(`lot plot: flagged units share colours ${p.boldColours}`);
    }
  }
  // (one per axis kind of the unit)
  const plotted = new Set(dom.unitPlots.map((p) => p.run));
  const flaggedRuns = new Set(flagged.map((r) => r.run_id));
  if (plotted.size !== flaggedRuns.size || [...plotted].some((run) => !flaggedRuns.has(run))) {
    fail(`unit plots for runs ${[...plotted]}, the runs needing a look are ${[...flaggedRuns]}`);
  }
  for (const p of dom.unitPlots) {
    if (!p.svg || p.curves < 1) fail(`unit plot '${p.caption}' has no curve`);
    if (p.textsOutside.length > 0) fail(`unit plot '${p.caption}': text outside the plot: ${p.textsOutside}`);
  }
  // ... and its raw samples against time: a rate panel and a drift panel per axis.
  for (const run of flaggedRuns) {
    const series = dom.unitPlots.filter((p) => p.run === run && p.series);
    const axesOfRun = rows.filter((r) => r.run_id === run).length;
    if (series.length !== 1) fail(`run ${run}: ${series.length} time-series plots, want 1`);
    else if (series[0].curves < 2 * axesOfRun) fail(`run ${run}: time-series plot has ${series[0].curves} lines for ${axesOfRun} axes`);
    // ... and each axis's dynamic Allan deviation, a curve per window.
    const davar = dom.unitPlots.filter((p) => p.run === run && p.davar);
    if (davar.length !== axesOfRun) fail(`run ${run}: ${davar.length} dynamic Allan plots for ${axesOfRun} axes`);
    else if (davar.some((p) => p.curves < 4)) fail(`run ${run}: a dynamic Allan plot with fewer than 4 windows`);
  }

  // Sorting (the first results table: the first axis kind's rows).
  const firstTable = rows.filter((r) => r.kind === rows[0]?.kind).length;
  const isSorted = (v, dir) => v.every((x, i) => i === 0 || dir * (x - v[i - 1]) >= 0);
  if (ascending.length !== firstTable || !isSorted(ascending, 1)) fail(`sorting by bias instability (ascending) gave ${ascending}`);
  if (descending.length !== firstTable || !isSorted(descending, -1)) fail(`sorting by bias instability (descending) gave ${descending}`);

  const seconds = ((Date.now() - started) / 1000).toFixed(1);
  if (failures.length > 0) {
    for (const f of failures) console.error(`report_check: FAIL: ${f}`);
    console.error(`report_check: ${failures.length} failure(s); the files are kept in ${work}`);
    process.exit(1);
  }
  console.log(`report_check: OK: ${rows.length} unit axes, ${dom.stats.length} statistics rows, ` +
              `${dom.lotPlots.length + dom.unitPlots.length} plots, no console error (${seconds} s)`);
  fs.rmSync(work, { recursive: true, force: true });
}

main().catch((e) => {
  console.error(`report_check: FAIL: ${e.message}`);
  if (work) console.error(`report_check: the files are kept in ${work}`);
  process.exit(1);
});
