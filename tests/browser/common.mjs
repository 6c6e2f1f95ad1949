// What the browser tests share: chromium (Debian's, headless, through playwright-core; exit 77
// skips a test without them), the agreement bounds and the comparison of the browser's read-back
// frame with the native client's (PSNR, the fraction within a per-channel tolerance, the
// identical fraction, a diff image), and a minimal PNG writer for a person to look at frames.

import fs from 'node:fs';
import zlib from 'node:zlib';

export const SKIP = 77;
const CHROMIUM = '/usr/bin/chromium';
// Measured agreement of the two warps (docs/remote-browser.md): identical frames with chromium's
// SwiftShader; the bounds leave room for another GPU's rounding of splat edges.
export const MIN_PSNR_DB = 40;
export const TOLERANCE = 16;  // per channel, of 255
export const MIN_FRACTION_WITHIN = 0.99;
export const MIN_FRACTION_IDENTICAL = 0.95;

// Headless chromium, or the test exits with SKIP when chromium or playwright-core is absent.
export async function launchChromium() {
    if (!fs.existsSync(CHROMIUM)) {
        console.log(`SKIP: ${CHROMIUM} is absent (scripts/install-deps.sh installs chromium)`);
        process.exit(SKIP);
    }
    let chromium;
    try {
        ({chromium} = await import('playwright-core'));
    } catch {
        console.log('SKIP: playwright-core is not installed (npm ci in tests/browser)');
        process.exit(SKIP);
    }
    return chromium.launch({
        executablePath: CHROMIUM,
        headless: true,
        args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
               '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    });
}

// A check printed as ok or FAIL; failed() says whether any failed.
export function checker() {
    let failed = false;
    const check = (ok, text) => {
        console.log(`${ok ? 'ok' : 'FAIL'}: ${text}`);
        if (!ok) failed = true;
    };
    return {check, failed: () => failed};
}

// The browser's frame against the native one with the bounds above: prints the figures, writes
// browser.png and diff.png into outDir, returns the comparison.
export function checkAgainstNative(check, browserRgba, nativeRgba, w, h, outDir, note = '') {
    check(browserRgba.length === nativeRgba.length, `frame sizes agree (${browserRgba.length} bytes)`);
    const r = compare(browserRgba, nativeRgba, w, h);
    writePng(`${outDir}/browser.png`, browserRgba, w, h);
    writePng(`${outDir}/diff.png`, r.diff, w, h);
    console.log(`browser vs native: PSNR ${r.psnr.toFixed(2)} dB, ${(100 * r.within).toFixed(2)}% of pixels ` +
                `within ${TOLERANCE}/255, ${(100 * r.exact).toFixed(2)}% identical${note}`);
    check(r.psnr >= MIN_PSNR_DB, `PSNR ${r.psnr.toFixed(2)} dB >= ${MIN_PSNR_DB} dB`);
    check(r.within >= MIN_FRACTION_WITHIN, `${(100 * r.within).toFixed(2)}% >= ${100 * MIN_FRACTION_WITHIN}% within tolerance`);
    check(r.exact >= MIN_FRACTION_IDENTICAL, `${(100 * r.exact).toFixed(2)}% >= ${100 * MIN_FRACTION_IDENTICAL}% of pixels identical`);
    return r;
}

// The point kernel's frames (positions and z-test alone) compared likewise.
export function checkPointKernel(check, browserRgba, nativeRgba, w, h) {
    const pr = compare(browserRgba, nativeRgba, w, h);
    console.log(`point kernel, browser vs native: PSNR ${pr.psnr.toFixed(2)} dB, ${(100 * pr.exact).toFixed(2)}% identical`);
    check(pr.exact >= MIN_FRACTION_IDENTICAL, `point kernel: ${(100 * pr.exact).toFixed(2)}% >= ` +
          `${100 * MIN_FRACTION_IDENTICAL}% of pixels identical`);
    return pr;
}

// PSNR over RGB, the fraction of pixels whose channels all lie within TOLERANCE, the identical
// fraction, and a diff image (absolute difference, x4).
export function compare(a, b, w, h) {
    let se = 0, within = 0, exact = 0;
    const diff = Buffer.alloc(w * h * 4);
    for (let i = 0; i < w * h; ++i) {
        let worst = 0;
        for (let c = 0; c < 3; ++c) {
            const d = a[4 * i + c] - b[4 * i + c];
            se += d * d;
            worst = Math.max(worst, Math.abs(d));
            diff[4 * i + c] = Math.min(255, 4 * Math.abs(d));
        }
        diff[4 * i + 3] = 255;
        if (worst <= TOLERANCE) ++within;
        if (worst === 0) ++exact;
    }
    const mse = se / (w * h * 3);
    return {psnr: mse === 0 ? Infinity : 10 * Math.log10(255 * 255 / mse), within: within / (w * h),
            exact: exact / (w * h), diff};
}

// A minimal RGBA PNG (for a person to look at the frames).
export function writePng(file, rgba, w, h) {
    const crcTable = Array.from({length: 256}, (_, n) => {
        let c = n;
        for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
        return c >>> 0;
    });
    const crc = (buf) => {
        let c = 0xffffffff;
        for (const x of buf) c = crcTable[(c ^ x) & 0xff] ^ (c >>> 8);
        return (c ^ 0xffffffff) >>> 0;
    };
    const chunk = (type, data) => {
        const len = Buffer.alloc(4);
        len.writeUInt32BE(data.length);
        const body = Buffer.concat([Buffer.from(type, 'ascii'), data]);
        const sum = Buffer.alloc(4);
        sum.writeUInt32BE(crc(body));
        return Buffer.concat([len, body, sum]);
    };
    const header = Buffer.alloc(13);
    header.writeUInt32BE(w, 0);
    header.writeUInt32BE(h, 4);
    header.set([8, 6, 0, 0, 0], 8);
    const raw = Buffer.alloc((w * 4 + 1) * h);
    for (let y = 0; y < h; ++y) rgba.copy(raw, y * (w * 4 + 1) + 1, y * w * 4, (y + 1) * w * 4);
    fs.writeFileSync(file, Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]),
                                          chunk('IHDR', header), chunk('IDAT', zlib.deflateSync(raw)),
                                          chunk('IEND', Buffer.alloc(0))]));
}
