// The browser client against a running server (issue 26, item 5): the test starts
// `parallax serve office:1` on a free loopback port, Debian's chromium (headless, playwright-core)
// loads the page from that server (`/?script`: a live session whose pose comes from
// window.plxScript), the script drives a pose path (the reference pose until a set rendered
// there arrives, then holds and turns to the destination pose) and reads the frame back. The
// native client's frame for the same poses comes from plx_browser_fixture in live mode: a
// libs/remote Client (the code of `parallax client`) in its own session with the same server,
// warping the set it receives for the reference pose. The server runs with --prediction none so
// that both sets are rendered exactly at the reference pose; the bounds are those of the
// recorded-message test (common.mjs): PSNR >= 40 dB, >= 99% of pixels within 16/255, >= 95%
// identical.
//
// Usage: node browser_live_test.mjs PARALLAX_EXE FIXTURE_EXE OUTDIR. Exit 0 pass, 1 fail, 77
// skipped (no chromium or no node_modules).

import {execFileSync, spawn} from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import readline from 'node:readline';

import {checkAgainstNative, checker, checkPointKernel, launchChromium} from './common.mjs';

const DEADLINE_MS = 80000;
const FACE_SIZE = 128;  // plx_browser_fixture's kFaceSize
const SAME_POSE = 1e-5;  // metres and unit-vector components
// The page's session normally starts within a second; the wait leaves room for a loaded machine.
const SESSION_WAIT_MS = 40000;

const [parallaxExe, fixtureExe, outDir] = process.argv.slice(2);
if (!parallaxExe || !fixtureExe || !outDir) {
    console.error('usage: node browser_live_test.mjs PARALLAX_EXE FIXTURE_EXE OUTDIR');
    process.exit(2);
}
const browser = await launchChromium();
const {check, failed} = checker();

// The server stops by itself (--seconds) if this process dies before it can stop it.
const server = spawn(parallaxExe, ['serve', 'office:1', '--port', '0', '--json', '--face-size', String(FACE_SIZE),
                                   '--prediction', 'none', '--threads', '2', '--seconds', '90'],
                     {stdio: ['ignore', 'pipe', 'inherit']});
const lines = readline.createInterface({input: server.stdout});
const serverLines = [];
const listening = new Promise((resolve) => lines.on('line', (l) => {
    serverLines.push(l);
    if (serverLines.length === 1) resolve(JSON.parse(l));
}));
const serverExited = new Promise((resolve) => server.on('exit', resolve));
const deadline = setTimeout(() => {
    console.error(`FAIL: not done within ${DEADLINE_MS / 1000} s`);
    server.kill('SIGTERM');
    process.exit(1);
}, DEADLINE_MS);

// Waits for the page's live session; on a timeout says where the page stands (no script, or the
// client's state and error) before failing.
async function waitForSession(page) {
    try {
        await page.waitForFunction(() => window.plxScript?.stats().state === 'session', null,
                                   {timeout: SESSION_WAIT_MS});
    } catch (e) {
        const where = await page.evaluate(
            () => (window.plxScript ? JSON.stringify(window.plxScript.stats()) : 'no plxScript on the page'));
        console.error(`FAIL: no session within ${SESSION_WAIT_MS / 1000} s: ${where}`);
        throw e;
    }
}

try {
    const {port} = await listening;
    check(port > 0, `parallax serve listening on 127.0.0.1:${port}`);
    fs.rmSync(outDir, {recursive: true, force: true});
    fs.mkdirSync(outDir, {recursive: true});
    execFileSync(fixtureExe, [outDir, `ws://127.0.0.1:${port}/`], {stdio: 'inherit'});
    const pose = JSON.parse(fs.readFileSync(path.join(outDir, 'pose.json'), 'utf8'));
    // A real picture to compare, not an empty one: the native frame is mostly covered.
    check(pose.holePixels < 0.05 * pose.width * pose.height,
          `native frame: ${pose.holePixels} uncovered pixels of ${pose.width * pose.height}`);

    const page = await browser.newPage({viewport: {width: pose.width + 40, height: pose.height + 40}});
    page.on('pageerror', (e) => console.log(`page error: ${e.message}`));
    const violations = [];
    page.on('console', (m) => {
        if (m.type() === 'error') console.log(`page console: ${m.text()}`);
        if (m.text().includes('Content Security Policy')) violations.push(m.text());
    });
    const response = await page.goto(`http://127.0.0.1:${port}/?script&face=${FACE_SIZE}`);
    check((response.headers()['content-security-policy'] ?? '').includes("connect-src 'self'"),
          `the page comes with its Content-Security-Policy`);
    // Its stylesheet applies (a page without it would still run, its overlay in the flow).
    check(await page.evaluate(() => getComputedStyle(document.getElementById('overlay')).position) === 'fixed',
          'the page\'s stylesheet applies');
    await waitForSession(page);

    // The pose path: the reference pose until a set rendered there has arrived, then hold (no
    // more poses sent, so that set stays the newest) and look from the destination pose.
    const t0 = Date.now();
    await page.evaluate((p) => plxScript.setPose(p), pose.reference);
    await page.waitForFunction(([p, eps]) => {
        const n = plxScript.newest();
        const near = (a, b) => a.every((v, i) => Math.abs(v - b[i]) <= eps);
        return n !== null && near(n.pose.eye, p.eye) && near(n.pose.forward, p.forward);
    }, [pose.reference, SAME_POSE], {timeout: 20000});
    await page.evaluate(() => plxScript.hold(true));
    console.log(`browser: first set at the reference pose after ${Date.now() - t0} ms`);
    await page.waitForTimeout(300);  // sets already requested arrive (rendered there too)
    const newest = await page.evaluate(() => plxScript.newest());
    const near = (a, b) => a.every((v, i) => Math.abs(v - b[i]) <= SAME_POSE);
    check(near(newest.pose.eye, pose.reference.eye), `the newest set (sequence ${newest.sequence}) is the reference pose's`);
    await page.evaluate((p) => plxScript.setPose(p), {eye: pose.eye, forward: pose.forward, up: pose.up});
    const frame = await page.evaluate(([w, h]) => plxScript.render(w, h), [pose.width, pose.height]);
    const pointFrame = await page.evaluate(([w, h]) => plxScript.render(w, h, 1), [pose.width, pose.height]);
    const stats = await page.evaluate(() => plxScript.stats());
    console.log(`browser: ${stats.references} sets (${stats.skipped} skipped), last ${stats.bytes} bytes, ` +
                `decoded in ${stats.decodeMs.toFixed(1)} ms; native set ${pose.setBytes} bytes`);
    check(stats.error === '' && stats.state === 'session', `the session is open and error-free (${stats.error})`);
    check(violations.length === 0, `no Content-Security-Policy violation (${violations.join('; ')})`);

    checkAgainstNative(check, Buffer.from(frame.rgba, 'base64'), fs.readFileSync(path.join(outDir, 'native.rgba')),
                       pose.width, pose.height, outDir);
    checkPointKernel(check, Buffer.from(pointFrame.rgba, 'base64'), fs.readFileSync(path.join(outDir, 'native_point.rgba')),
                     pose.width, pose.height);
} finally {
    await browser.close();
    server.kill('SIGTERM');
    await serverExited;
    clearTimeout(deadline);
}
// The server's totals: two sessions (the native client's, the page's), nothing refused.
const stopped = JSON.parse(serverLines.at(-1) ?? '{}');
check(stopped.event === 'stopped' && stopped.sessions_total === 2 && stopped.protocol_errors === 0,
      `server: ${stopped.sessions_total} sessions, ${stopped.protocol_errors} protocol errors, ${stopped.sets_sent} sets`);
process.exit(failed() ? 1 : 0);
