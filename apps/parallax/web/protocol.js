// The v1 wire protocol of docs/remote-protocol.md for the browser: encoders for what the page
// sends (ClientHello, Pose, Ping, Pong, Error) and a decoder that reads every received message as
// untrusted bytes (DataView, each size checked against the bytes present and the spec's limits
// before anything is allocated, every f32 finite, unknown types, versions, codecs and reserved
// bits refused, trailing bytes refused). Errors are ProtocolError with one line naming the field.

export const PROTOCOL_VERSION = 1;
export const CODEC_VERSION = 1;
export const MessageType = {
    clientHello: 1, serverHello: 2, pose: 3, referenceSet: 4,
    ping: 5, pong: 6, error: 7, bye: 8,
};
const TYPE_NAMES = ['', 'client hello', 'server hello', 'pose', 'reference set', 'ping', 'pong',
                    'error', 'bye'];
// Size limits per message type (the spec's table); a bigger message is refused before reading.
export const MESSAGE_LIMITS = [0, 512, 2048, 256, 64 << 20, 13, 13, 2048, 2048];
// The decoder's limits (DecodeLimits' defaults).
export const LIMITS = {
    maxViewSide: 4096, maxViewPixels: 4096 * 4096, maxViews: 6, maxSetPixels: 6 * 4096 * 4096,
};
export const MAX_TEXT_BYTES = 1024;
export const ColorCodec = {jpeg: 1, zstd: 2};
export const DisparityCodec = {q16: 1, floatZstd: 2, q16Deflate: 3};
// ClientHello's disparityCodecs bit of a codec: bit (codec - 1). The browser has no zstd.
export const BROWSER_DISPARITY_CODECS = 1 << (DisparityCodec.q16Deflate - 1);
export const Layout = {cube4: 0, cube6: 1, wide: 2};

// The limits a set of a session may reach: those of `base` narrowed to the views the accepted
// ServerHello's layout has and to its face size (the wide view is faceSize rows of any width up
// to base's side), as the native client's announcedLimits (libs/remote/protocol.h).
export function announcedLimits(hello, base = LIMITS) {
    const wide = hello.layout === Layout.wide;
    const maxViewSide = wide ? base.maxViewSide : Math.min(base.maxViewSide, hello.faceSize);
    const maxViewPixels = Math.min(base.maxViewPixels, hello.faceSize * maxViewSide);
    const views = hello.layout === Layout.cube6 ? 6 : wide ? 1 : 4;
    const maxViews = Math.min(base.maxViews, views);
    return {maxViewSide, maxViewPixels, maxViews,
            maxSetPixels: Math.min(base.maxSetPixels, maxViewPixels * maxViews)};
}

export class ProtocolError extends Error {}

// Bounds-checked little-endian reader; the first failure throws naming the context and field.
class Reader {
    constructor(bytes, context) {
        this.bytes = bytes;
        this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
        this.pos = 0;
        this.context = context;
    }
    fail(text) { throw new ProtocolError(`${this.context}: ${text}`); }
    left() { return this.bytes.byteLength - this.pos; }
    need(n, field) {
        if (this.left() < n) this.fail(`truncated at ${field} (need ${n} bytes, ${this.left()} left)`);
    }
    u8(field) { this.need(1, field); return this.view.getUint8(this.pos++); }
    u16(field) { this.need(2, field); const v = this.view.getUint16(this.pos, true); this.pos += 2; return v; }
    u32(field) { this.need(4, field); const v = this.view.getUint32(this.pos, true); this.pos += 4; return v; }
    // Microsecond timestamps: exact as a Number up to 2^53 (285 years of microseconds).
    u64(field) {
        this.need(8, field);
        const lo = this.view.getUint32(this.pos, true), hi = this.view.getUint32(this.pos + 4, true);
        this.pos += 8;
        return hi * 4294967296 + lo;
    }
    // All 64 bits, for a field echoed back (a Ping's timestamp: the peer's clock, any value).
    u64Exact(field) {
        this.need(8, field);
        const v = this.view.getBigUint64(this.pos, true);
        this.pos += 8;
        return v;
    }
    f32(field) {
        this.need(4, field);
        const v = this.view.getFloat32(this.pos, true);
        this.pos += 4;
        if (!Number.isFinite(v)) this.fail(`${field} is not finite`);
        return v;
    }
    vec3(field) { return [this.f32(field), this.f32(field), this.f32(field)]; }
    take(n, field) {
        if (n > this.left()) this.fail(`${field} of ${n} bytes past the end (${this.left()} left)`);
        const s = this.bytes.subarray(this.pos, this.pos + n);
        this.pos += n;
        return s;
    }
    // A `u32 size` then that many bytes, size >= 1 and within what is left.
    sized(field) {
        const n = this.u32(field);
        if (n === 0 || n > this.left()) this.fail(`${field} ${n} past the end (${this.left()} left)`);
        return this.take(n, field);
    }
    text(field, max) {
        const n = this.u16(field);
        if (n > max) this.fail(`${field} ${n} over ${max}`);
        return new TextDecoder('utf-8', {fatal: false}).decode(this.take(n, field));
    }
    end() { if (this.left() !== 0) this.fail(`${this.left()} trailing bytes`); }
}

// Little-endian writer into a growing byte array.
class Writer {
    constructor() { this.bytes = []; }
    u8(v) { this.bytes.push(v & 0xff); }
    u16(v) { this.u8(v); this.u8(v >>> 8); }
    u32(v) { for (let i = 0; i < 4; ++i) this.u8(v >>> (8 * i)); }
    // v: a BigInt or an integer Number.
    u64(v) {
        const b = BigInt(v);
        this.u32(Number(b & 0xffffffffn));
        this.u32(Number(b >> 32n));
    }
    f32(v) {
        const b = new Uint8Array(new Float32Array([v]).buffer);
        for (const x of b) this.u8(x);
    }
    vec3(v) { this.f32(v[0]); this.f32(v[1]); this.f32(v[2]); }
    text(s) {
        const b = new TextEncoder().encode(s);
        this.u16(b.length);
        for (const x of b) this.u8(x);
    }
    done() { return new Uint8Array(this.bytes); }
}

export function encodeClientHello({layout = Layout.cube4, faceSize = 512, token = ''}) {
    const w = new Writer();
    w.u8(MessageType.clientHello);
    w.u16(PROTOCOL_VERSION);
    w.u8(layout);
    w.u16(faceSize);
    w.text(token);
    w.u8(BROWSER_DISPARITY_CODECS);
    return w.done();
}

// pose: {eye, forward, up} (unit vectors); velocity: [x, y, z] m/s or null.
export function encodePose(timestampUs, pose, velocity) {
    const w = new Writer();
    w.u8(MessageType.pose);
    w.u64(timestampUs);
    w.vec3(pose.eye);
    w.vec3(pose.forward);
    w.vec3(pose.up);
    w.u8(velocity ? 1 : 0);
    w.vec3(velocity ?? [0, 0, 0]);
    return w.done();
}

export function encodePing(type, timestampUs, nonce) {
    const w = new Writer();
    w.u8(type);
    w.u64(timestampUs);
    w.u32(nonce);
    return w.done();
}

export function encodeError(code, text) {
    const w = new Writer();
    w.u8(MessageType.error);
    w.u16(code);
    w.text(text.slice(0, 256));
    return w.done();
}

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]];
const len = (a) => Math.sqrt(dot(a, a));

// warp::checkPose: forward and up of non-zero length and not parallel.
function checkPose(r, pose) {
    const c = len(cross(pose.forward, pose.up));
    if (!(len(pose.forward) > 0 && len(pose.up) > 0 && c > 1e-6 * len(pose.forward) * len(pose.up))) {
        r.fail('pose: up is parallel to forward or a vector is zero');
    }
}

// Camera::create's checks: eye != target, up not parallel to the view direction, 0 < fov < 180,
// 0 < near < far.
function checkCamera(r, c) {
    const dir = [c.target[0] - c.eye[0], c.target[1] - c.eye[1], c.target[2] - c.eye[2]];
    if (len(dir) === 0) r.fail('camera: eye equals target');
    if (!(len(cross(dir, c.up)) > 1e-6 * len(dir) * len(c.up))) r.fail('camera: up is parallel to the view direction');
    if (!(c.fovY > 0 && c.fovY < 180)) r.fail(`camera: fovYDegrees ${c.fovY} outside (0, 180)`);
    if (!(c.near > 0 && c.near < c.far)) r.fail(`camera: near ${c.near}, far ${c.far} invalid`);
}

// One encoded reference view, up to its payloads (decoded later by decode.js).
function readView(bytes, limits) {
    const r = new Reader(bytes, 'reference view');
    const version = r.u8('version');
    if (version !== CODEC_VERSION) r.fail(`codec version ${version} (this decoder reads ${CODEC_VERSION})`);
    const colorCodec = r.u8('colorCodec'), disparityCodec = r.u8('disparityCodec');
    if (colorCodec !== ColorCodec.jpeg && colorCodec !== ColorCodec.zstd) r.fail(`unknown colorCodec ${colorCodec}`);
    if (disparityCodec < 1 || disparityCodec > 3) r.fail(`unknown disparityCodec ${disparityCodec}`);
    const reserved = r.u8('reserved');
    if (reserved !== 0) r.fail(`reserved byte is ${reserved}`);
    // What the browser cannot decode: zstd payloads (it asked for q16-deflate only).
    if (colorCodec !== ColorCodec.jpeg) r.fail(`colorCodec ${colorCodec} (zstd) is not decodable here`);
    if (disparityCodec !== DisparityCodec.q16Deflate) {
        r.fail(`disparityCodec ${disparityCodec} was not asked for (this client decodes 3, q16-deflate)`);
    }
    const width = r.u16('width'), height = r.u16('height');
    if (width < 1 || height < 1 || width > limits.maxViewSide || height > limits.maxViewSide ||
        width * height > limits.maxViewPixels) {
        r.fail(`size ${width}x${height} outside 1..${limits.maxViewSide} a side and ${limits.maxViewPixels} pixels`);
    }
    const camera = {
        eye: r.vec3('eyePos'), target: r.vec3('targetPos'), up: r.vec3('upDir'),
        fovY: r.f32('fovYDegrees'), near: r.f32('nearPlane'), far: r.f32('farPlane'),
        shift: [r.f32('principalShiftPx'), r.f32('principalShiftPx')], width, height,
    };
    checkCamera(r, camera);
    const dmin = r.f32('dmin'), dmax = r.f32('dmax');
    if (!((dmin === 0 && dmax === 0) || (dmin > 0 && dmax >= dmin))) {
        r.fail(`disparity range [${dmin}, ${dmax}] invalid for its codec`);
    }
    r.need(height * 8, 'row ranges');
    const rowMin = new Float32Array(height), rowMax = new Float32Array(height);
    for (let y = 0; y < height; ++y) rowMin[y] = r.f32('rowMinDisparity');
    for (let y = 0; y < height; ++y) rowMax[y] = r.f32('rowMaxDisparity');
    for (let y = 0; y < height; ++y) {
        if (!(rowMin[y] >= 0 && rowMax[y] >= rowMin[y])) {
            r.fail(`row ${y} disparity range [${rowMin[y]}, ${rowMax[y]}] invalid`);
        }
    }
    const color = r.sized('colorBytes');
    const disparity = r.sized('disparityBytes');
    r.end();
    return {camera, width, height, colorCodec, disparityCodec, dmin, dmax, rowMin, rowMax, color,
            disparity};
}

function readReferenceSet(r, limits) {
    const version = r.u8('version');
    if (version !== CODEC_VERSION) r.fail(`codec version ${version} (this decoder reads ${CODEC_VERSION})`);
    const count = r.u8('viewCount');
    const maxViews = Math.min(6, limits.maxViews);
    if (count < 1 || count > maxViews) r.fail(`viewCount ${count} outside 1..${maxViews}`);
    const reserved = r.u16('reserved');
    if (reserved !== 0) r.fail(`reserved field is ${reserved}`);
    const pose = {eye: r.vec3('eye'), forward: r.vec3('forward'), up: r.vec3('up')};
    checkPose(r, pose);
    const renderMs = r.f32('renderMs');
    if (!(renderMs >= 0 && renderMs < 1e6)) r.fail(`renderMs ${renderMs} outside [0, 1e6)`);
    // Every view's bytes first, so the set's pixel budget is checked before any is decoded.
    const spans = [];
    let pixels = 0;
    for (let i = 0; i < count; ++i) {
        const s = r.sized('viewBytes');
        if (s.length >= 8) pixels += (s[4] | (s[5] << 8)) * (s[6] | (s[7] << 8));
        spans.push(s);
    }
    r.end();
    if (pixels > limits.maxSetPixels) r.fail(`${pixels} pixels over the limit ${limits.maxSetPixels}`);
    const views = spans.map((s, i) => {
        try {
            return readView(s, limits);
        } catch (e) {
            if (e instanceof ProtocolError) throw new ProtocolError(`reference set: view ${i}: ${e.message}`);
            throw e;
        }
    });
    return {pose, renderMs, views};
}

// Decodes one received message (an ArrayBuffer or Uint8Array of untrusted bytes) into a plain
// object {type, ...}; reference sets keep their payloads as views into the bytes. Throws
// ProtocolError.
export function parseMessage(data, limits = LIMITS) {
    const bytes = data instanceof Uint8Array ? data : new Uint8Array(data);
    if (bytes.length === 0) throw new ProtocolError('message: empty');
    const type = bytes[0];
    if (type < 1 || type > 8) throw new ProtocolError(`unknown message type ${type}`);
    const name = TYPE_NAMES[type];
    if (bytes.length > MESSAGE_LIMITS[type]) {
        throw new ProtocolError(`${name} message: ${bytes.length} bytes over the limit ${MESSAGE_LIMITS[type]}`);
    }
    const r = new Reader(bytes, `${name} message`);
    r.u8('type');
    let m;
    switch (type) {
        case MessageType.serverHello: {
            const version = r.u16('version');
            if (version !== PROTOCOL_VERSION) r.fail(`protocol version ${version} (this client speaks ${PROTOCOL_VERSION})`);
            const accepted = r.u8('accepted');
            if (accepted > 1) r.fail(`accepted is ${accepted}`);
            const layout = r.u8('layout');
            if (layout > 2) r.fail(`unknown layout ${layout}`);
            const faceSize = r.u16('faceSize');
            if (faceSize < 16 || faceSize > 4096) r.fail(`faceSize ${faceSize} outside 16..4096`);
            const poseRateHz = r.u16('poseRateHz');
            if (poseRateHz < 1 || poseRateHz > 1000) r.fail(`poseRateHz ${poseRateHz} outside 1..1000`);
            const reason = r.text('reasonBytes', MAX_TEXT_BYTES);
            if ((accepted === 1) !== (reason.length === 0)) r.fail(`reasonBytes ${reason.length} for accepted ${accepted}`);
            m = {type: 'serverHello', accepted: accepted === 1, layout, faceSize, poseRateHz, reason};
            break;
        }
        case MessageType.referenceSet: {
            const sequence = r.u32('sequence');
            const requestTimestampUs = r.u64('requestTimestampUs');
            const sr = new Reader(bytes.subarray(r.pos), 'reference set message: reference set');
            return {type: 'referenceSet', sequence, requestTimestampUs, set: readReferenceSet(sr, limits),
                    bytes: bytes.length};
        }
        case MessageType.ping:
        case MessageType.pong:
            m = {type: type === MessageType.ping ? 'ping' : 'pong', timestampUs: r.u64Exact('timestampUs'),
                 nonce: r.u32('nonce')};
            break;
        case MessageType.error: {
            const code = r.u16('code');
            if (code < 1 || code > 5) r.fail(`unknown code ${code}`);
            m = {type: 'error', code, text: r.text('textBytes', MAX_TEXT_BYTES)};
            break;
        }
        case MessageType.bye: {
            const code = r.u16('code');
            if (code > 2) r.fail(`unknown reason ${code}`);
            m = {type: 'bye', code, text: r.text('textBytes', MAX_TEXT_BYTES)};
            break;
        }
        default:
            // ClientHello and Pose travel client to server only.
            r.fail('not a message a server sends');
    }
    r.end();
    return m;
}
