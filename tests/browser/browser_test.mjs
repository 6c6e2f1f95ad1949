// The browser client in a real browser (issue 26, item 5): Debian's chromium, headless, driven by
// playwright-core, loads the page served over HTTP on 127.0.0.1 in its test mode, is fed the
// ServerHello and ReferenceSet messages a server sends (plx_browser_fixture writes them) through
// the same parsing, decoding and WebGL2 warping code as the socket path, renders the destination
// pose, and the read-back frame is compared with the native client's frame (libs/remote decode +
// warp::Warper) of the same bytes and pose: PSNR and the fraction of pixels within a tolerance.
// Every truncated prefix and random bit flips of both messages are refused with one line (or, for
// a flip, decode), never another exception; a truncated message stops the page visibly; Pings
// are answered with the native client's Pong bytes, at most 10 a second, none while backed up; a
// set beyond its ServerHello's face size or answering a pose from the future is refused, and a
// Pong that does not echo the last Ping's timestamp is no round trip; a server silent for 30 s
// stops the page.
//
// Usage: node browser_test.mjs FIXTURE_EXE OUTDIR. Exit 0 pass, 1 fail, 77 skipped (no chromium
// or no node_modules: `npm ci` in this folder, which scripts/install-deps.sh runs).

import {execFileSync} from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';

import {checkAgainstNative, checker, checkPointKernel, launchChromium} from './common.mjs';

const DEADLINE_MS = 55000;

const [fixtureExe, outDir] = process.argv.slice(2);
if (!fixtureExe || !outDir) {
    console.error('usage: node browser_test.mjs FIXTURE_EXE OUTDIR');
    process.exit(2);
}

// A hard bound on the whole test; playwright stops the browser it launched when node exits.
const deadline = setTimeout(() => {
    console.error(`FAIL: not done within ${DEADLINE_MS / 1000} s`);
    process.exit(1);
}, DEADLINE_MS);

fs.rmSync(outDir, {recursive: true, force: true});
fs.mkdirSync(outDir, {recursive: true});
execFileSync(fixtureExe, [outDir], {stdio: 'inherit'});
const pose = JSON.parse(fs.readFileSync(path.join(outDir, 'pose.json'), 'utf8'));

// Serves only the fixture's files: the embedded page under /, the messages under /data/.
const TYPES = {'.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8',
               '.css': 'text/css; charset=utf-8'};
const files = new Map();
for (const name of fs.readdirSync(path.join(outDir, 'web'))) {
    files.set(`/${name}`, path.join(outDir, 'web', name));
}
files.set('/', path.join(outDir, 'web', 'index.html'));
for (const name of ['server_hello.bin', 'reference_set.bin', 'ping.bin']) files.set(`/data/${name}`, path.join(outDir, name));
const server = http.createServer((req, res) => {
    const file = files.get(new URL(req.url, 'http://x').pathname);
    if (!file) {
        res.writeHead(404).end();
        return;
    }
    res.writeHead(200, {'content-type': TYPES[path.extname(file)] ?? 'application/octet-stream'});
    res.end(fs.readFileSync(file));
});
await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
const origin = `http://127.0.0.1:${server.address().port}`;

const browser = await launchChromium();
const {check, failed} = checker();

try {
    const page = await browser.newPage({viewport: {width: pose.width + 40, height: pose.height + 40}});
    page.on('pageerror', (e) => console.log(`page error: ${e.message}`));
    page.on('console', (m) => {
        if (m.type() === 'error') console.log(`page console: ${m.text()}`);
    });
    // A fresh page in test mode (a stopped one takes no more messages).
    const openTestPage = async () => {
        await page.goto(`${origin}/?test`);
        await page.waitForFunction(() => window.plxTest?.ready === true);
    };
    await openTestPage();

    const t0 = Date.now();
    check(await page.evaluate(() => plxTest.feed('/data/server_hello.bin')) === '', 'server hello accepted');
    const setError = await page.evaluate(() => plxTest.feed('/data/reference_set.bin'));
    check(setError === '', `reference set decoded${setError ? `: ${setError}` : ''}`);
    await page.evaluate((p) => plxTest.setPose(p), {eye: pose.eye, forward: pose.forward, up: pose.up});
    const frame = await page.evaluate(([w, h]) => plxTest.render(w, h), [pose.width, pose.height]);
    const stats = await page.evaluate(() => plxTest.stats());
    console.log(`browser: decode ${stats.decodeMs.toFixed(1)} ms, decode + warp + read back ${Date.now() - t0} ms ` +
                '(headless SwiftShader)');

    checkAgainstNative(check, Buffer.from(frame.rgba, 'base64'), fs.readFileSync(path.join(outDir, 'native.rgba')),
                       pose.width, pose.height, outDir,
                       ` (${pose.holePixels} native hole pixels of ${pose.width * pose.height}; set ${pose.setBytes} bytes)`);

    const pointFrame = await page.evaluate(([w, h]) => plxTest.render(w, h, 1), [pose.width, pose.height]);
    checkPointKernel(check, Buffer.from(pointFrame.rgba, 'base64'), fs.readFileSync(path.join(outDir, 'native_point.rgba')),
                     pose.width, pose.height);

    // The page's parser and decoders on damaged bytes: every truncated prefix of both messages
    // refused, bit flips decoded or refused, never another exception.
    for (const [name, flips] of [['server_hello.bin', 200], ['reference_set.bin', 300]]) {
        const d = await page.evaluate(([u, n]) => plxTest.checkDamaged(u, n), [`/data/${name}`, flips]);
        console.log(`${name}: ${d.prefixesRefused}/${d.prefixes} prefixes refused, ${d.flipsRefused}/${d.flips} ` +
                    `bit flips refused${d.unexpected.length ? `; unexpected: ${d.unexpected.slice(0, 3).join(' | ')}` : ''}`);
        check(d.prefixesRefused === d.prefixes && d.unexpected.length === 0,
              `${name}: every prefix refused, every flip decoded or refused with one line`);
    }

    // A damaged message stops the page with one line, shown to the viewer.
    await openTestPage();
    await page.evaluate(() => plxTest.feed('/data/server_hello.bin'));
    const set = fs.readFileSync(path.join(outDir, 'reference_set.bin'));
    const truncated = set.subarray(0, Math.floor(set.length / 2)).toString('base64');
    const error = await page.evaluate((b) => plxTest.feedBytes(b), truncated);
    const shown = await page.locator('#error').innerText();
    console.log(`truncated set: "${error}"`);
    check(error !== '' && !error.includes('\n') && shown === error, 'a truncated set is refused with one visible line');

    // Pings (docs/remote-protocol.md): refused before the server hello; after it, answered by
    // the native client's Pong bytes, at most 10 times a second, and not while the socket is
    // backed up (a server that stops reading gets no queue of them).
    await openTestPage();
    const early = await page.evaluate(() => plxTest.feed('/data/ping.bin'));
    check(early === 'ping before the server hello', `a ping before the server hello is refused ("${early}")`);
    const pong = fs.readFileSync(path.join(outDir, 'pong.bin')).toString('base64');
    const answers = async (backedUpFirst, pings) => {
        await openTestPage();
        return page.evaluate(async ([first, n]) => {
            await plxTest.feed('/data/server_hello.bin');
            plxTest.backedUp(first);
            await plxTest.feed('/data/ping.bin');
            const whileBackedUp = plxTest.sent().length;
            plxTest.backedUp(false);
            for (let i = 1; i < n; ++i) await plxTest.feed('/data/ping.bin');
            return {whileBackedUp, sent: plxTest.sent(), error: plxTest.stats().error};
        }, [backedUpFirst, pings]);
    };
    const flood = await answers(false, 25);
    console.log(`pings: 25 answered by ${flood.sent.length} pongs`);
    check(flood.error === '' && flood.sent.length === 10 && flood.sent.every((b) => b === pong),
          'ten pongs to 25 pings within a second, each the native Pong of its ping');
    const backedUp = await answers(true, 2);
    check(backedUp.error === '' && backedUp.whileBackedUp === 0 && backedUp.sent.length === 1 &&
          backedUp.sent[0] === pong, 'no pong while the socket is backed up; the next ping answered');

    // A server held to its ServerHello, as the native client holds it (docs/remote-protocol.md):
    // a set larger than the announced face size, or answering a pose from the future, is
    // refused before it is decoded; a Pong counts as a round trip only if it echoes the last
    // Ping's nonce and timestamp.
    const hello = fs.readFileSync(path.join(outDir, 'server_hello.bin'));
    const feedAfterHello = async (helloBytes, setBytes) => {
        await openTestPage();
        return page.evaluate(async ([h, m]) => {
            await plxTest.feedBytes(h);
            return {error: await plxTest.feedBytes(m), stats: plxTest.stats()};
        }, [helloBytes.toString('base64'), setBytes.toString('base64')]);
    };
    const smallHello = Buffer.from(hello);
    smallHello.writeUInt16LE(pose.faceSize / 2, 5);  // type, version u16, accepted, layout, faceSize
    const oversized = await feedAfterHello(smallHello, set);
    console.log(`set over the announced face: "${oversized.error}"`);
    check(oversized.error.includes(`over the limit ${(pose.faceSize / 2) ** 2 * 4}`) &&
          oversized.stats.references === 0, 'a set beyond the announced face size is refused');
    const future = Buffer.from(set);
    future.writeBigUInt64LE(2n ** 64n - 1n, 5);  // type, sequence u32, requestTimestampUs
    const fromFuture = await feedAfterHello(hello, future);
    check(fromFuture.error === 'reference set answers a pose timestamped after its arrival' &&
          fromFuture.stats.references === 0, `a set from the future is refused ("${fromFuture.error}")`);
    await openTestPage();
    const echoes = await page.evaluate(async (h) => {
        await plxTest.feedBytes(h);
        plxTest.ping();
        const ping = Uint8Array.from(atob(plxTest.sent().at(-1)), (c) => c.charCodeAt(0));
        const pongOf = (timestamp) => {
            const b = new Uint8Array(ping);
            b[0] = 6;  // MessageType.pong
            if (timestamp !== undefined) new DataView(b.buffer).setBigUint64(1, timestamp, true);
            return btoa(String.fromCharCode(...b));
        };
        await plxTest.feedBytes(pongOf(2n ** 64n - 1n));
        const forged = plxTest.stats().rttMs;
        await plxTest.feedBytes(pongOf());
        return {forged, echoed: plxTest.stats().rttMs, error: plxTest.stats().error};
    }, hello.toString('base64'));
    console.log(`pongs: forged timestamp rtt ${echoes.forged}, echo rtt ${echoes.echoed}`);
    check(echoes.error === '' && echoes.forged === null && echoes.echoed >= 0,
          'a pong with a forged timestamp is no round trip; the echo of the ping is');

    // A server silent for 30 s (no Ping, no set) is gone: the page stops with the native
    // client's line.
    await openTestPage();
    const silent = await page.evaluate(async (h) => {
        await plxTest.feedBytes(h);
        return [plxTest.silentFor(29000), plxTest.silentFor(30001)];
    }, hello.toString('base64'));
    check(silent[0] === '' && silent[1] === 'no message from the server for 30.0 s',
          `a server silent for 30 s stops the page ("${silent[0]}", "${silent[1]}")`);
} finally {
    await browser.close();
    server.close();
    clearTimeout(deadline);
}
process.exit(failed() ? 1 : 0);
