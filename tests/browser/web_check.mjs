// `imuqual serve` in a real browser, checked against the archive.
//
// GIVEN a small real archive (4 simulated VG700-like gyros, a short soak on
//       purpose so that every unit FAILs with reasons) whose plan name and
//       operator are hostile HTML,
// WHEN  `imuqual serve` serves it over TLS (a self-signed certificate made
//       here) with a new token (--new-token) on a loopback port, and
//       headless Chromium opens it once with ?token= and walks it: the lots
//       page, the lot's report, each unit's history and each run's page,
// THEN  the token cookie is Secure, HttpOnly and SameSite=Strict and carries
//       every page after the first; without it the server answers 401;
//       every page loads with no console error (a script refused by the
//       Content-Security-Policy is one), no page error and no request to
//       anything but the server; the lots row equals the lot_overview view;
//       the report's tables sort (its script, served as a file, runs); each
//       run page's measurements equal the archive's (sqlite3) value for
//       value, bit for bit (data-v); the hostile strings show as text and
//       run nothing; links lead lot -> report, unit -> runs, run -> run
//       page; a POST is refused. Then the same server in plain HTTP on
//       loopback without a token (the local default): the lots page and the
//       sorting report.
//
// Usage: node web_check.mjs --imuqual BIN [--chromium PATH]
// Exit status 0 when every check passes, 1 otherwise (each failure is one
// line on stderr).
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import {
  fail, finish, launch, makeCertificate, parseArgs, run, screenCheck, serve, sqlite, sqlText, waitFor,
  watchedPage,
} from './check_lib.mjs';

const kLot = 'WEB';
const kUnits = 4;
const kPlanSource = new URL('../../plans/vg700ca.textproto', import.meta.url);
const kPlanName = 'vg700 <script>window.injected = 1</script> & "q"';
const kOperator = 'ana"><img src=x onerror="window.injected=2">';

function sameExact(pageText, dbValue) {
  if (dbValue === null || dbValue === undefined) return pageText === null || pageText === '';
  return pageText !== null && pageText !== '' && Number(pageText) === dbValue;
}

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const started = Date.now();
  const work = fs.mkdtempSync(path.join(os.tmpdir(), 'imuqual-web-'));
  const db = path.join(work, 'web.db');
  const plan = path.join(work, 'plan.textproto');
  fs.writeFileSync(plan, fs.readFileSync(kPlanSource, 'utf8')
      .replace(/^name: .*$/m, `name: ${JSON.stringify(kPlanName)}`));
  run(args.imuqual, ['run', '--sim', String(kUnits), '--duration', '600', '--lot', kLot, '--db', db,
                     '--plan', plan, '--operator', kOperator, '--short-soak', '--quiet']);
  const { cert, key } = makeCertificate(work);
  const tokenFile = path.join(work, 'token');
  const { child, url: base } = await serve(args.imuqual, ['--db', db, '--tls-cert', cert, '--tls-key', key,
                                                          '--new-token', '--token-file', tokenFile]);
  if (!base.startsWith('https://')) fail(`served at ${base}, not over TLS`);
  const token = fs.readFileSync(tokenFile, 'utf8').trim();
  if ((fs.statSync(tokenFile).mode & 0o777) !== 0o600) fail('the token file is not owner-only');
  const origin = new URL(base).origin;
  const context = await launch(args, work);
  let plain = null;
  let historyServer = null;
  try {
    const page = await watchedPage(context, origin);
    const visit = async (url) => {
      const response = await page.goto(url, { waitUntil: 'load', timeout: 30000 });
      if (!response || response.status() !== 200) fail(`${url}: status ${response?.status()}`);
      if (await page.evaluate(() => window.injected !== undefined)) fail(`${url}: a hostile string ran`);
    };
    // The report's tables sort on a click: its script ran.
    const sorts = async (where) => {
      const sorted = await page.evaluate(() => {
        const th = document.querySelector('table.sortable thead th');
        if (!th) return 'no sortable table';
        th.click();
        return th.getAttribute('aria-sort');
      });
      if (sorted !== 'ascending') fail(`${where}: the report's table did not sort (${sorted})`);
    };

    // Without the token: 401 and nothing else.
    const stranger = await context.request.get(`${base}api/lots`);
    if (stranger.status() !== 401) fail(`without the token: status ${stranger.status()}`);

    // The lots page, opened once with the token: it leaves the cookie.
    await visit(`${base}?token=${token}`);
    const cookie = (await context.cookies(origin)).find((c) => c.name === 'imuqual_token');
    if (!cookie) {
      fail('no token cookie after ?token=');
    } else if (!cookie.secure || !cookie.httpOnly || cookie.sameSite !== 'Strict') {
      fail(`the token cookie is not Secure, HttpOnly, SameSite=Strict: ${JSON.stringify(cookie)}`);
    }
    // The lots page: the lot's row equals the lot_overview view.
    await visit(base);
    const overview = sqlite(db, `SELECT * FROM lot_overview WHERE lot = ${sqlText(kLot)}`)[0];
    const lotRow = await page.evaluate((lot) => {
      const rows = [...document.querySelectorAll('table.data tbody tr')];
      const row = rows.find((tr) => tr.cells[0].textContent === lot);
      if (!row) return null;
      const head = [...document.querySelectorAll('table.data thead th')].map((th) => th.textContent);
      const out = { href: row.cells[0].querySelector('a')?.getAttribute('href') };
      head.forEach((h, i) => { out[h] = row.cells[i].getAttribute('data-v') ?? row.cells[i].textContent; });
      return out;
    }, kLot);
    if (!lotRow) {
      fail(`the lots page has no row for ${kLot}`);
    } else {
      for (const k of ['units', 'runs', 'pass', 'marginal', 'fail']) {
        if (Number(lotRow[k]) !== overview[k]) fail(`lots page ${k} ${lotRow[k]}, lot_overview ${overview[k]}`);
      }
      // The lot's page is its report.
      await visit(new URL(lotRow.href, base).href);
      const title = await page.title();
      if (!title.startsWith(`Lot ${kLot}`)) fail(`lot page title '${title}'`);
      const planText = await page.evaluate(() => document.querySelector('[data-field="plan"]')?.textContent);
      if (!planText?.includes(kPlanName)) fail(`the plan's name is not shown as text: '${planText}'`);
      await sorts('the lot page over TLS');
      // Its slow sections, left to the page's script, arrive: the noise
      // models, the lot's Allan plots, the flagged units' plots (every unit
      // here FAILs) with the links of the attention list leading to them.
      await waitFor(page, 'the lot page\'s deferred sections', 30,
                    () => document.querySelector('section[data-src]') === null &&
                          document.querySelector('#lot-model table.lot-model') !== null &&
                          document.querySelectorAll('#lot-plots figure svg').length > 0 &&
                          document.querySelectorAll('#unit-plots figure svg').length > 0);
      const dangling = await page.evaluate(() => [...document.querySelectorAll('#attention a[href^="#"]')]
          .map((a) => a.getAttribute('href')).filter((h) => !document.querySelector(h)));
      if (dangling.length > 0) fail(`the attention list links to no plot: ${dangling.join(' ')}`);
      await screenCheck(page, 'lot', [{ what: 'the first failing unit', selector: '#attention li[data-verdict="FAIL"]' }]);
    }

    // Each unit: its history links to its run, whose measurements equal the archive's.
    const runs = sqlite(db, `SELECT run_id, serial FROM runs WHERE lot = ${sqlText(kLot)} ORDER BY serial`);
    if (runs.length !== kUnits) fail(`${runs.length} runs archived, ${kUnits} expected`);
    for (const r of runs) {
      await visit(`${base}unit/${encodeURIComponent(r.serial)}`);
      const link = await page.evaluate((id) => [...document.querySelectorAll('a')]
          .find((a) => a.textContent === id)?.getAttribute('href'), r.run_id);
      if (!link) { fail(`unit ${r.serial}: no link to run ${r.run_id}`); continue; }
      await visit(new URL(link, base).href);
      const shown = await page.evaluate(() => {
        const table = document.querySelector('#measurements table.data');
        const head = [...table.querySelectorAll('thead th')].map((th) => th.textContent);
        return [...table.querySelectorAll('tbody tr')].map((tr) => {
          const o = {};
          head.forEach((h, i) => { o[h] = { v: tr.cells[i].getAttribute('data-v'), text: tr.cells[i].textContent }; });
          return o;
        });
      });
      const archived = sqlite(db, `SELECT m.axis, m.name, m.value, m.uncertainty, m.unit, m.low, m.high, m.outcome
                                   FROM measurements m JOIN runs USING (run_key)
                                   WHERE run_id = ${sqlText(r.run_id)}`);
      if (shown.length !== archived.length) fail(`run ${r.run_id}: ${shown.length} measurements shown, ${archived.length} archived`);
      for (const m of archived) {
        const axis = m.axis === '' ? '(run)' : m.axis;
        const row = shown.find((s) => s.axis.text === axis && s.measurement.text === m.name);
        if (!row) { fail(`run ${r.run_id}: ${axis} ${m.name} not shown`); continue; }
        for (const [col, want] of [['value', m.value], ['uncertainty', m.uncertainty], ['low', m.low], ['high', m.high]]) {
          if (!sameExact(row[col].v, want)) fail(`run ${r.run_id} ${axis} ${m.name} ${col}: page ${row[col].v}, archive ${want}`);
        }
        // Shown as a measurement is quoted: u to two significant digits, the value to its place.
        if (m.uncertainty > 0 && m.value !== null) {
          const uShown = Number(row.uncertainty.text), vShown = Number(row.value.text);
          if (Math.abs(uShown - Number(Number(m.uncertainty).toPrecision(2))) > 1e-12 * m.uncertainty) fail(`run ${r.run_id} ${axis} ${m.name}: uncertainty shown '${row.uncertainty.text}', not ${m.uncertainty} to two significant digits`);
          if (!(Math.abs(vShown - m.value) <= Math.max(m.uncertainty / 19, Math.abs(m.value) * 1e-9))) fail(`run ${r.run_id} ${axis} ${m.name}: value shown '${row.value.text}' is not ${m.value} to its uncertainty's place`);
        }
        if (row.unit.text !== m.unit) fail(`run ${r.run_id} ${axis} ${m.name} unit: page ${row.unit.text}, archive ${m.unit}`);
        if (row.outcome.text !== (m.outcome ?? 'not_judged')) fail(`run ${r.run_id} ${axis} ${m.name} outcome: page ${row.outcome.text}, archive ${m.outcome}`);
      }
      const operator = await page.evaluate(() => [...document.querySelectorAll('dt')]
          .find((dt) => dt.textContent === 'operator')?.nextElementSibling?.textContent);
      if (operator !== kOperator) fail(`run ${r.run_id}: operator shown as '${operator}'`);
      const plots = await page.evaluate(() => document.querySelectorAll('figure svg').length);
      if (plots < 2) fail(`run ${r.run_id}: ${plots} plots (Allan and raw samples expected)`);
      // Each axis's dynamic Allan deviation: one plot per axis, a curve per window.
      const davar = await page.evaluate(() => [...document.querySelectorAll('figure svg')]
          .filter((s) => (s.getAttribute('aria-label') || '').endsWith('dynamic Allan deviation'))
          .map((s) => s.querySelectorAll('polyline').length));
      const axesShown = sqlite(db, `SELECT COUNT(DISTINCT m.axis) AS n FROM measurements m JOIN runs USING (run_key) WHERE run_id = ${sqlText(r.run_id)} AND m.name = 'bias_instability'`)[0].n;
      if (davar.length !== axesShown) fail(`run ${r.run_id}: ${davar.length} dynamic Allan plots for ${axesShown} axes`);
      if (davar.some((curves) => curves < 4)) fail(`run ${r.run_id}: a dynamic Allan plot with fewer than 4 windows: ${davar}`);
      if (r === runs[0]) {
        await screenCheck(page, 'run', [{ what: 'the run\'s verdict', selector: '.verdict' },
                                        { what: 'its failing measurement', selector: '#judged tbody tr' }]);
        const firstJudged = await page.evaluate(() => document.querySelector('#judged tbody tr')?.cells[10]?.textContent);
        if (firstJudged !== 'FAIL') fail(`run ${r.run_id}: the first judged measurement is ${firstJudged}, not the FAIL`);
      }
    }

    // Read-only.
    const post = await context.request.post(base, { data: 'x=1' });
    if (post.status() !== 405) fail(`POST answered ${post.status()}`);

    // Plain HTTP on loopback, no token: the local default.
    child.kill('SIGTERM');
    const local = await serve(args.imuqual, ['--db', db]);
    plain = local.child;
    if (!local.url.startsWith('http://')) fail(`the plain server is at ${local.url}`);
    const plainPage = await watchedPage(context, new URL(local.url).origin, { fresh: true });
    const plainLot = await plainPage.goto(`${local.url}lot/${kLot}`, { waitUntil: 'load', timeout: 30000 });
    if (plainLot?.status() !== 200) fail(`plain HTTP lot page: status ${plainLot?.status()}`);
    const sortedPlain = await plainPage.evaluate(() => {
      const th = document.querySelector('table.sortable thead th');
      th?.click();
      return th?.getAttribute('aria-sort');
    });
    if (sortedPlain !== 'ascending') fail(`plain HTTP lot page: the table did not sort (${sortedPlain})`);

    // The compare page of two generated lots (the second drifted): it fits
    // the screen, and the measurements that differ come first, in view.
    const history = path.join(work, 'history.db');
    run(path.join(path.dirname(args.imuqual), 'imuqual-history-gen'),
        ['--db', history, '--lots', '2', '--units', '30', '--drift', '0.3']);
    const hist = await serve(args.imuqual, ['--db', history]);
    historyServer = hist.child;
    const comparePage = await watchedPage(context, new URL(hist.url).origin, { fresh: true });
    const compared = await comparePage.goto(`${hist.url}compare?a=HIST-L001&b=HIST-L002`,
                                            { waitUntil: 'load', timeout: 30000 });
    if (compared?.status() !== 200) fail(`compare page: status ${compared?.status()}`);
    await screenCheck(comparePage, 'compare', [{ what: 'the first measurement that differs', selector: 'tr.sig' }]);
  } finally {
    await context.close();
    child.kill('SIGTERM');
    plain?.kill('SIGTERM');
    historyServer?.kill('SIGTERM');
  }
  const seconds = ((Date.now() - started) / 1000).toFixed(1);
  finish('web_check', `over TLS with a token: lots page, report, ${kUnits} units and runs against ` +
         `the archive, no console error, no outside request; plain HTTP on loopback (${seconds} s)`,
         work, () => fs.rmSync(work, { recursive: true, force: true }));
}

main().catch((e) => {
  console.error(`web_check: FAIL: ${e.message}`);
  process.exit(1);
});
