// Payload decoding in the browser (docs/remote-protocol.md, "Encoded reference view"): colour
// JPEG through createImageBitmap after its frame header was checked against the view's size, and
// q16-deflate disparity through DecompressionStream('deflate') into exactly 2 W H bytes, then the
// inverse of q16's row prediction and quantisation, clamped to each row's exact range as the
// native decoder does (the same double arithmetic, rounded once to f32).

import {ProtocolError} from './protocol.js';

// The size in a JPEG's frame header (SOFn), read before anything is decoded, so that a header
// claiming more pixels than the view is refused before the browser allocates for it.
export function jpegSize(b) {
    if (b.length < 4 || b[0] !== 0xff || b[1] !== 0xd8) throw new ProtocolError('colour: not a JPEG');
    let p = 2;
    while (p + 4 <= b.length) {
        if (b[p] !== 0xff) throw new ProtocolError(`colour: JPEG marker expected at ${p}`);
        const marker = b[p + 1];
        if (marker === 0xff) { ++p; continue; }  // fill byte
        const length = (b[p + 2] << 8) | b[p + 3];
        if (length < 2 || p + 2 + length > b.length) throw new ProtocolError('colour: JPEG segment past the end');
        const sof = marker >= 0xc0 && marker <= 0xcf && marker !== 0xc4 && marker !== 0xc8 && marker !== 0xcc;
        if (sof) {
            if (length < 7) throw new ProtocolError('colour: JPEG frame header too short');
            return {height: (b[p + 5] << 8) | b[p + 6], width: (b[p + 7] << 8) | b[p + 8]};
        }
        if (marker === 0xda) break;  // scan data before any frame header
        p += 2 + length;
    }
    throw new ProtocolError('colour: JPEG without a frame header');
}

export async function decodeColor(view) {
    const s = jpegSize(view.color);
    if (s.width !== view.width || s.height !== view.height) {
        throw new ProtocolError(`colour JPEG is ${s.width}x${s.height}, the view ${view.width}x${view.height}`);
    }
    let bitmap;
    try {
        bitmap = await createImageBitmap(new Blob([view.color], {type: 'image/jpeg'}),
                                         {colorSpaceConversion: 'none', premultiplyAlpha: 'none'});
    } catch (e) {
        throw new ProtocolError(`colour: JPEG does not decode (${e.message})`);
    }
    if (bitmap.width !== view.width || bitmap.height !== view.height) {
        bitmap.close();
        throw new ProtocolError('colour: decoded JPEG differs from the view size');
    }
    return bitmap;
}

// RFC 1950: method 8, window <= 32 KiB, check bits, no preset dictionary; 8 bytes at least.
function checkZlibHeader(b) {
    if (b.length < 8) throw new ProtocolError(`disparity: zlib stream of ${b.length} bytes is too short`);
    const cmf = b[0], flg = b[1];
    if ((cmf & 0x0f) !== 8 || (cmf >> 4) > 7 || (cmf * 256 + flg) % 31 !== 0 || (flg & 0x20) !== 0) {
        throw new ProtocolError('disparity: not a zlib deflate stream');
    }
}

// Inflates into exactly `size` bytes: a stream that produces more is cancelled at the first byte
// past it, one that ends short is refused; DecompressionStream checks the Adler-32 and refuses
// bytes after the stream.
export async function inflateExact(b, size) {
    checkZlibHeader(b);
    const out = new Uint8Array(size);
    let filled = 0;
    const reader = new Blob([b]).stream().pipeThrough(new DecompressionStream('deflate')).getReader();
    try {
        for (;;) {
            const {done, value} = await reader.read();
            if (done) break;
            if (filled + value.length > size) {
                throw new ProtocolError(`disparity: zlib stream inflates past ${size} bytes`);
            }
            out.set(value, filled);
            filled += value.length;
        }
    } catch (e) {
        reader.cancel().catch(() => {});
        if (e instanceof ProtocolError) throw e;
        throw new ProtocolError(`disparity: zlib: ${e.message}`);
    }
    if (filled !== size) throw new ProtocolError(`disparity: zlib stream of ${filled} bytes, expected ${size}`);
    return out;
}

// q16's prediction (disparity_q16.cpp): 2a - b clamped to 0..65535 inside a row of drawn pixels,
// the left neighbour next to an empty one or at x = 1, the row above's first code at x = 0.
function predict(q, x, aboveFirst) {
    if (x === 0) return aboveFirst;
    const a = q[x - 1];
    if (x === 1) return a;
    const b = q[x - 2];
    if (a === 0 || b === 0) return a;
    return Math.min(65535, Math.max(0, 2 * a - b));
}

// Residual planes (low bytes, then high bytes; zigzag) to 1/w per pixel, row-major.
export function reconstructDisparity(planes, view) {
    const {width: w, height: h, dmin, dmax, rowMin, rowMax} = view;
    const n = w * h;
    const step = (dmax - dmin) / 65534;  // doubles, as the native decoder
    const out = new Float32Array(n);
    const q = new Uint16Array(w);
    let aboveFirst = 0;
    for (let y = 0; y < h; ++y) {
        const lo = rowMin[y], hi = rowMax[y];
        for (let x = 0; x < w; ++x) {
            const i = y * w + x;
            const z = planes[i] | (planes[n + i] << 8);
            const r = (z >>> 1) ^ -(z & 1);
            const c = (predict(q, x, aboveFirst) + r) & 0xffff;
            q[x] = c;
            out[i] = c === 0 ? 0 : Math.min(hi, Math.max(lo, Math.fround(dmin + (c - 1) * step)));
        }
        aboveFirst = q[0];
    }
    return out;
}

// Decodes every view of a parsed reference set: {bitmap, disparity} per view.
export async function decodeViews(set) {
    return Promise.all(set.views.map(async (view, i) => {
        try {
            const [bitmap, planes] = await Promise.all([
                decodeColor(view), inflateExact(view.disparity, 2 * view.width * view.height)]);
            return {bitmap, disparity: reconstructDisparity(planes, view)};
        } catch (e) {
            if (e instanceof ProtocolError) throw new ProtocolError(`reference set: view ${i}: ${e.message}`);
            throw e;
        }
    }));
}
