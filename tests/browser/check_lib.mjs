// What the browser checks share: arguments, running the imuqual command and
// sqlite3, collecting failures, Chromium with a page that reports console
// errors and requests outside the server, a self-signed certificate for
// 127.0.0.1, and `imuqual serve` started on a free loopback port.
import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { chromium } from 'playwright-core';

// --imuqual BIN [--chromium PATH]
export function parseArgs(argv) {
  const args = { chromium: '/usr/bin/chromium' };
  for (let i = 0; i < argv.length; i += 2) {
    const key = argv[i].replace(/^--/, '');
    if (!['imuqual', 'chromium'].includes(key) || i + 1 >= argv.length) {
      throw new Error(`unknown or incomplete argument '${argv[i]}'`);
    }
    args[key] = argv[i + 1];
  }
  if (!args.imuqual) throw new Error('--imuqual BIN is required');
  return args;
}

export function run(file, args) {
  try {
    return execFileSync(file, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
  } catch (e) {
    throw new Error(`${path.basename(file)} ${args.join(' ')} failed (exit ${e.status}): ` +
                    `${(e.stderr || '').trim()}`);
  }
}

export function sqlText(s) { return `'${s.replace(/'/g, "''")}'`; }
export function sqlite(db, sql) {
  const out = run('sqlite3', ['-json', '-bail', '-readonly', db, sql]).trim();
  return out === '' ? [] : JSON.parse(out);
}

export const failures = [];
export function fail(message) { failures.push(message); }

// Prints the failures (exit 1) or the success line; `work` is kept on failure.
export function finish(name, okLine, work, removeWork) {
  if (failures.length > 0) {
    for (const f of failures) console.error(`${name}: FAIL: ${f}`);
    console.error(`${name}: ${failures.length} failure(s); the files are kept in ${work}`);
    process.exit(1);
  }
  console.log(`${name}: OK: ${okLine}`);
  removeWork();
}

// Headless Chromium with a profile under `work`. It accepts the test's
// self-signed certificate (ignoreHTTPSErrors), and so does context.request.
export function launch(args, work) {
  return chromium.launchPersistentContext(path.join(work, 'profile'), {
    executablePath: args.chromium,
    headless: true,
    ignoreHTTPSErrors: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
           '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    timeout: 60000,
  });
}

// A self-signed certificate for 127.0.0.1 (P-256, two days) and its key
// (owner-only, as serve wants it), made by the openssl command in `work`.
export function makeCertificate(work) {
  const cert = path.join(work, 'cert.pem');
  const key = path.join(work, 'key.pem');
  run('openssl', ['req', '-x509', '-newkey', 'ec', '-pkeyopt', 'ec_paramgen_curve:P-256', '-nodes',
                  '-days', '2', '-subj', '/CN=127.0.0.1', '-addext', 'subjectAltName=IP:127.0.0.1',
                  '-keyout', key, '-out', cert]);
  fs.chmodSync(key, 0o600);
  return { cert, key };
}

// A station's keys made by `imuqual keygen` in `work` (README, "Trust"):
// { station, trust, runArgs }. runArgs: the flags that give `imuqual run`
// the station key, the roles' public keys and each role its signing key; a
// live page needs only `--trust` (it takes what the roles signed).
export function makeStationKeys(imuqual, work) {
  const dir = path.join(work, 'keys');
  fs.mkdirSync(dir, { mode: 0o700 });
  const station = path.join(dir, 'station.key');
  run(imuqual, ['keygen', '--out', station]);
  const runArgs = ['--key-file', station];
  let trust = '';
  for (const role of ['acquire', 'analyze', 'store']) {
    const key = path.join(dir, `${role}.key`);
    run(imuqual, ['keygen', '--role', role, '--out', key]);
    trust += fs.readFileSync(`${key}.pub`, 'utf8');
    runArgs.push('--sign-key', `${role}=${key}`);
  }
  const trustFile = path.join(dir, 'station.trust');
  fs.writeFileSync(trustFile, trust);
  runArgs.push('--trust', trustFile);
  return { station, trust: trustFile, runArgs };
}

// The context's page (a new one when `fresh`), failing on console errors and
// warnings, page errors and any request outside `origin` (or data: URLs).
export async function watchedPage(context, origin, { fresh = false } = {}) {
  const page = (!fresh && context.pages()[0]) || await context.newPage();
  page.on('console', (msg) => {
    if (msg.type() === 'error' || msg.type() === 'warning') fail(`console ${msg.type()}: ${msg.text()}`);
  });
  page.on('pageerror', (err) => fail(`page error: ${err.message}`));
  page.on('request', (req) => {
    const u = req.url();
    if (origin && !u.startsWith(origin + '/') && !u.startsWith('data:')) fail(`request outside the server: ${u}`);
  });
  return page;
}

// Starts `imuqual serve --listen 127.0.0.1:0 EXTRA...`; resolves to
// { child, url } once it prints a line matching `pattern` (its group 1).
export function serve(imuqual, extra, pattern = /at (https?:\/\/127\.0\.0\.1:\d+\/)/) {
  const child = spawn(imuqual, ['serve', ...extra, '--listen', '127.0.0.1:0'],
                      { stdio: ['ignore', 'pipe', 'pipe'] });
  return new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error(`serve printed no URL: ${out}`)), 20000);
    child.stdout.on('data', (d) => {
      out += d;
      const m = pattern.exec(out);
      if (m) {
        clearTimeout(timer);
        resolve({ child, url: m[1] });
      }
    });
    child.on('exit', (code) => reject(new Error(`serve exited ${code}: ${out}`)));
  });
}

// Resolves true when `predicate` (run in the page with `arg`) holds; false,
// with a failure, after `seconds`.
export async function waitFor(page, what, seconds, predicate, arg) {
  const deadline = Date.now() + seconds * 1000;
  for (;;) {
    if (await page.evaluate(predicate, arg)) return true;
    if (Date.now() > deadline) {
      fail(`${what}: not seen within ${seconds} s`);
      return false;
    }
    await new Promise((r) => setTimeout(r, 200));
  }
}

// The p-quantile (0..1) of `values`, nearest rank; NaN when empty.
export function percentile(values, p) {
  if (values.length === 0) return NaN;
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.min(sorted.length - 1, Math.max(0, Math.ceil(p * sorted.length) - 1))];
}
