// The browser client of `parallax serve` (docs/remote-browser.md): connects a WebSocket to the
// serving origin, speaks the v1 protocol (docs/remote-protocol.md) asking for q16-deflate
// disparity, decodes each reference set and warps the newest one to the viewer's pose every
// display frame (warp.js), so that walking never waits for the network. WASD or the arrows walk,
// R and F rise and sink, Shift runs, dragging the mouse looks around. The overlay shows the
// display frame rate, the reference age (now minus the time of the pose the newest set was
// rendered for), the round-trip time of the last ping, and the sets received.
//
// URL parameters: ws=PATH (the WebSocket path on this origin, default /ws), token=T, face=N
// (requested face size, default 512), test (no network: window.plxTest feeds messages through
// the same parsing, decoding and warping code, reads back the frame and what the page would have
// sent), script (a live session whose pose comes from window.plxScript instead of the keyboard
// and mouse).

import {announcedLimits, encodeClientHello, encodeError, encodePing, encodePose, Layout, LIMITS,
        MessageType, parseMessage, ProtocolError} from './protocol.js';
import {decodeViews} from './decode.js';
import {displayCamera, GlWarper} from './warp.js';

const params = new URLSearchParams(location.search);
const canvas = document.getElementById('view');
const overlay = document.getElementById('overlay');
const errorBox = document.getElementById('error');

const nowUs = () => Math.round((performance.timeOrigin + performance.now()) * 1000);
const WALK_SPEED = 1.5;      // metres per second; Shift triples it
const LOOK_DEG_PER_PX = 0.2;  // mouse drag
const PING_INTERVAL_MS = 1000;
// `parallax serve` pings every 500 ms: a server silent this long is gone (the native client's
// ClientConfig::silenceTimeoutMs).
const SILENCE_MS = 30000;
const MAX_BUFFERED_BYTES = 1 << 16;  // skip a pose, ping or pong while this much is unsent

const normalize = (v) => {
    const l = Math.hypot(v[0], v[1], v[2]);
    return [v[0] / l, v[1] / l, v[2] / l];
};
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]];

class Client {
    constructor() {
        this.warper = new GlWarper(canvas);
        this.pose = null;  // {eye, forward, up}
        this.yaw = 0;
        this.pitch = 0;
        this.velocity = [0, 0, 0];
        this.keys = new Set();
        this.queue = Promise.resolve();
        this.state = 'hello';  // hello -> session -> closed
        this.limits = LIMITS;  // a set's limits; the accepted ServerHello narrows them
        this.lastSequence = -1;
        this.reference = null;  // {requestTimestampUs, sequence}
        this.poseRateHz = 0;
        this.ping = {nonce: 0, sentUs: 0, answered: true, answersThisSecond: 0};
        this.stats = {fps: 0, referenceAgeMs: null, rttMs: null, references: 0, skipped: 0,
                      bytes: 0, decodeMs: 0, frames: 0};
        this.setsWaiting = 0;  // reference sets received and not yet handled
        this.lastMessageMs = performance.now();  // the server's latest message (or page load)
        this.error = '';
        this.held = false;  // plxScript.hold: no poses sent
    }

    // Every received message, in arrival order (decoding is asynchronous): a bad one stops the
    // session with a one-line error.
    receive(data) {
        this.lastMessageMs = performance.now();
        const isSet = data instanceof ArrayBuffer && data.byteLength > 0 &&
            new Uint8Array(data, 0, 1)[0] === MessageType.referenceSet;
        if (isSet) this.setsWaiting += 1;
        this.queue = this.queue.then(() => this.handle(data, isSet)).catch((e) => this.fail(e));
        return this.queue;
    }

    async handle(data, isSet = false) {
        if (isSet) this.setsWaiting -= 1;
        if (this.state === 'closed') return;
        if (!(data instanceof ArrayBuffer)) throw new ProtocolError('text frame (the protocol is binary)');
        const m = parseMessage(data, this.limits);
        if (this.state === 'hello' && m.type !== 'serverHello' && m.type !== 'error' && m.type !== 'bye') {
            throw new ProtocolError(`${m.type} before the server hello`);
        }
        switch (m.type) {
            case 'serverHello':
                if (this.state !== 'hello') throw new ProtocolError('a second server hello');
                if (!m.accepted) return this.stop(`server refused: ${m.reason}`);
                this.state = 'session';
                this.limits = announcedLimits(m);
                this.poseRateHz = m.poseRateHz;
                this.onSession?.();
                return;
            case 'referenceSet':
                return this.acceptSet(m);
            case 'ping':
                // At most 10 answers a second (the spec's ping rate).
                if (this.ping.answersThisSecond++ < 10) this.sendControl(encodePing(MessageType.pong, m.timestampUs, m.nonce));
                return;
            case 'pong':
                // A round trip only when it echoes the last Ping sent, nonce and timestamp.
                if (m.nonce === this.ping.nonce && m.timestampUs === BigInt(this.ping.sentUs) &&
                    !this.ping.answered) {
                    this.ping.answered = true;
                    this.stats.rttMs = (nowUs() - Number(m.timestampUs)) / 1000;
                }
                return;
            case 'error':
                return this.stop(`server error ${m.code}: ${m.text}`);
            case 'bye':
                return this.stop(`server said bye (${m.code})${m.text ? `: ${m.text}` : ''}`, false);
            default:
                throw new ProtocolError(`unexpected ${m.type}`);
        }
    }

    async acceptSet(m) {
        if (m.sequence <= this.lastSequence) {
            throw new ProtocolError(`reference set sequence ${m.sequence} after ${this.lastSequence}`);
        }
        // The pose it answers was sent by this page, so it cannot be later than now.
        if (m.requestTimestampUs > nowUs()) {
            throw new ProtocolError('reference set answers a pose timestamped after its arrival');
        }
        // A newer set already waits behind this one (decoding is slower than the link, as in
        // software WebGL): skip to it rather than let the reference age grow with the queue.
        if (this.setsWaiting > 0) {
            this.lastSequence = m.sequence;
            this.stats.skipped += 1;
            return;
        }
        const t0 = performance.now();
        const decoded = await decodeViews(m.set);
        this.stats.decodeMs = performance.now() - t0;
        this.warper.upload(m.set, decoded);
        this.lastSequence = m.sequence;
        this.reference = {requestTimestampUs: m.requestTimestampUs, sequence: m.sequence, pose: m.set.pose};
        this.stats.references += 1;
        this.stats.bytes = m.bytes;
        if (!this.pose) this.setPose(m.set.pose);
    }

    // An exact pose (the test hook, the first set's pose); input continues from its direction.
    setPose(pose) {
        this.pose = {eye: [...pose.eye], forward: [...pose.forward], up: [...pose.up]};
        this.yaw = Math.atan2(pose.forward[0], -pose.forward[2]);
        this.pitch = Math.asin(Math.max(-1, Math.min(1, pose.forward[1])));
    }

    // Walks and turns by the keys held and the mouse dragged since the last frame.
    updatePose(dt, dragPx) {
        if (!this.pose) return;
        if (dragPx[0] !== 0 || dragPx[1] !== 0) {
            this.yaw += dragPx[0] * LOOK_DEG_PER_PX * Math.PI / 180;
            this.pitch = Math.max(-1.48, Math.min(1.48, this.pitch - dragPx[1] * LOOK_DEG_PER_PX * Math.PI / 180));
            const cp = Math.cos(this.pitch);
            this.pose.forward = [cp * Math.sin(this.yaw), Math.sin(this.pitch), -cp * Math.cos(this.yaw)];
            const right = normalize(cross(this.pose.forward, [0, 1, 0]));
            this.pose.up = cross(right, this.pose.forward);
        }
        const k = (...names) => names.some((n) => this.keys.has(n));
        const flat = normalize([this.pose.forward[0], 0, this.pose.forward[2]]);
        const right = normalize(cross(flat, [0, 1, 0]));
        const along = (k('KeyW', 'ArrowUp') ? 1 : 0) - (k('KeyS', 'ArrowDown') ? 1 : 0);
        const side = (k('KeyD', 'ArrowRight') ? 1 : 0) - (k('KeyA', 'ArrowLeft') ? 1 : 0);
        const rise = (k('KeyR') ? 1 : 0) - (k('KeyF') ? 1 : 0);
        const speed = WALK_SPEED * (k('ShiftLeft', 'ShiftRight') ? 3 : 1);
        this.velocity = [0, 1, 2].map((i) => speed * (along * flat[i] + side * right[i] + (i === 1 ? rise : 0)));
        this.pose.eye = this.pose.eye.map((e, i) => e + this.velocity[i] * dt);
    }

    render(w, h, maxSplat) {
        if (!this.pose || this.warper.views.length === 0) return false;
        this.warper.render(displayCamera(this.pose, w, h), maxSplat);
        this.stats.referenceAgeMs = this.reference.requestTimestampUs
            ? (nowUs() - this.reference.requestTimestampUs) / 1000 : null;
        this.stats.frames += 1;
        return true;
    }

    send(bytes) {
        if (this.socket?.readyState === WebSocket.OPEN) this.socket.send(bytes);
    }

    // A Ping or Pong, unless the socket is backed up: a server that stops reading gets no queue
    // of them (docs/remote-protocol.md, "Limits").
    sendControl(bytes) {
        if (this.socket?.bufferedAmount > MAX_BUFFERED_BYTES) return;
        this.send(bytes);
    }

    sendPose() {
        if (!this.pose || this.held || this.state !== 'session' ||
            this.socket.bufferedAmount > MAX_BUFFERED_BYTES) return;
        const moving = this.velocity.some((v) => v !== 0);
        this.send(encodePose(nowUs(), this.pose, moving ? this.velocity : null));
    }

    sendPing() {
        if (this.state !== 'session') return;
        this.ping.answersThisSecond = 0;
        this.ping.nonce = (this.ping.nonce + 1) >>> 0;
        this.ping.answered = false;
        this.ping.sentUs = nowUs();
        this.sendControl(encodePing(MessageType.ping, this.ping.sentUs, this.ping.nonce));
    }

    // Stops the page once the server has sent nothing for SILENCE_MS at `nowMs`.
    checkSilence(nowMs = performance.now()) {
        if (this.state !== 'closed' && nowMs - this.lastMessageMs > SILENCE_MS) {
            this.stop(`no message from the server for ${(SILENCE_MS / 1000).toFixed(1)} s`);
        }
    }

    // A protocol violation: tell the server (Error kProtocol), close, show the line.
    fail(e) {
        const line = String(e instanceof Error ? e.message : e).split('\n')[0];
        if (e instanceof ProtocolError) this.send(encodeError(1, line));
        this.stop(line);
    }

    stop(line, isError = true) {
        this.state = 'closed';
        this.error = line;
        errorBox.textContent = line;
        errorBox.style.display = 'block';
        errorBox.style.background = isError ? '#a02828' : '#555';
        this.socket?.close();
    }
}

function connect(client) {
    const url = new URL(params.get('ws') ?? '/ws', location.href);
    url.protocol = location.protocol === 'https:' ? 'wss:' : 'ws:';
    const socket = new WebSocket(url);
    socket.binaryType = 'arraybuffer';
    client.socket = socket;
    setInterval(() => client.checkSilence(), PING_INTERVAL_MS);
    socket.onopen = () => socket.send(encodeClientHello({
        layout: Layout.cube4, faceSize: Number(params.get('face') ?? 512), token: params.get('token') ?? ''}));
    socket.onmessage = (event) => client.receive(event.data);
    socket.onclose = (event) => {
        if (client.state !== 'closed') client.stop(`connection closed (${event.code}${event.reason ? `: ${event.reason}` : ''})`);
    };
    client.onSession = () => {
        setInterval(() => client.sendPose(), 1000 / client.poseRateHz);
        setInterval(() => client.sendPing(), PING_INTERVAL_MS);
        client.sendPing();
    };
}

function interactive(client) {
    const drag = [0, 0];
    canvas.addEventListener('pointerdown', (e) => canvas.setPointerCapture(e.pointerId));
    canvas.addEventListener('pointermove', (e) => {
        if (e.buttons) {
            drag[0] += e.movementX;
            drag[1] += e.movementY;
        }
    });
    addEventListener('keydown', (e) => client.keys.add(e.code));
    addEventListener('keyup', (e) => client.keys.delete(e.code));
    addEventListener('blur', () => client.keys.clear());
    let last = performance.now(), fpsStart = last, fpsFrames = 0, overlayAt = 0;
    const frame = (t) => {
        const dt = Math.min(0.1, (t - last) / 1000);
        last = t;
        client.updatePose(dt, drag);
        drag[0] = drag[1] = 0;
        const w = Math.max(1, Math.round(canvas.clientWidth)), h = Math.max(1, Math.round(canvas.clientHeight));
        if (canvas.width !== w || canvas.height !== h) {
            canvas.width = w;
            canvas.height = h;
        }
        if (client.render(w, h)) ++fpsFrames;
        if (t - fpsStart >= 1000) {
            client.stats.fps = fpsFrames * 1000 / (t - fpsStart);
            fpsStart = t;
            fpsFrames = 0;
        }
        if (t - overlayAt > 250) {
            overlayAt = t;
            const s = client.stats, f = (v, d = 0) => (v === null ? '-' : v.toFixed(d));
            overlay.textContent = `${f(s.fps)} fps  reference age ${f(s.referenceAgeMs)} ms  ` +
                `RTT ${f(s.rttMs, 1)} ms\n${s.references} sets (${s.skipped} skipped), last ${(s.bytes / 1024).toFixed(0)} KiB, ` +
                `decoded in ${f(s.decodeMs)} ms`;
        }
        requestAnimationFrame(frame);
    };
    requestAnimationFrame(frame);
}

function base64(bytes) {
    let s = '';
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
    return btoa(s);
}

// Warps the newest set to the client's pose on a w x h canvas and reads the frame back (the
// hooks). maxSplat: 1 for the point kernel; the derivative splat's cap when absent.
function readFrame(client, w, h, maxSplat) {
    canvas.width = w;
    canvas.height = h;
    canvas.style.width = `${w}px`;
    canvas.style.height = `${h}px`;
    if (!client.render(w, h, maxSplat)) throw new Error('nothing to render (no reference set yet)');
    return {width: w, height: h, rgba: base64(client.warper.readPixels(w, h))};
}

// The scripted hook on a live session: the page connects and speaks the protocol as usual, but
// its pose comes from the script (sent at the server's pose rate, without velocity); hold(true)
// stops sending poses, so the newest set stays the newest while the script renders other poses
// from it.
function scriptHook(client) {
    overlay.textContent = 'scripted';
    window.plxScript = {
        setPose(pose) { client.setPose(pose); },
        hold(on) { client.held = on; },
        newest: () => (client.reference ? {...client.reference} : null),
        render: (w, h, maxSplat) => readFrame(client, w, h, maxSplat),
        stats: () => ({...client.stats, error: client.error, state: client.state}),
        ready: true,
    };
}

// The test hook: messages from files through the socket path's code, an exact pose, the frame,
// and what the page sends, recorded in place of a socket.
function testHook(client) {
    overlay.textContent = 'test mode';
    const sent = [];
    const socket = {readyState: WebSocket.OPEN, bufferedAmount: 0, send: (bytes) => sent.push(bytes),
                    close() {}};
    client.socket = socket;
    window.plxTest = {
        async feed(url) {
            const response = await fetch(url);
            if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
            await client.receive(await response.arrayBuffer());
            return client.error;
        },
        async feedBytes(base64Text) {
            const bytes = Uint8Array.from(atob(base64Text), (c) => c.charCodeAt(0));
            await client.receive(bytes.buffer);
            return client.error;
        },
        setPose(pose) { client.setPose(pose); },
        render: (w, h, maxSplat) => readFrame(client, w, h, maxSplat),
        stats: () => ({...client.stats, error: client.error, state: client.state}),
        // The messages sent so far (base64 each); backedUp(true) plays a server that stopped
        // reading (more unsent than the page lets queue).
        sent: () => sent.map(base64),
        backedUp(on) { socket.bufferedAmount = on ? 2 * MAX_BUFFERED_BYTES : 0; },
        ping() { client.sendPing(); },  // a Ping, as the session's timer sends one
        // The silence check as if `ms` had passed since the last message; the page's error.
        silentFor(ms) {
            client.checkSilence(client.lastMessageMs + ms);
            return client.error;
        },
        // The message at `url` damaged: every truncated prefix must be refused by the parser, and
        // `flips` single-bit flips (a fixed pseudo-random sequence) must parse and decode or be
        // refused with a one-line ProtocolError; anything else is listed in `unexpected`.
        async checkDamaged(url, flips) {
            const good = new Uint8Array(await (await fetch(url)).arrayBuffer());
            const result = {prefixes: good.length, prefixesRefused: 0, flips, flipsRefused: 0,
                            unexpected: []};
            const refused = (e) => {
                if (e instanceof ProtocolError && e.message && !e.message.includes('\n')) return true;
                result.unexpected.push(String(e?.message ?? e));
                return false;
            };
            for (let n = 0; n < good.length; ++n) {
                try {
                    parseMessage(good.slice(0, n).buffer);
                    result.unexpected.push(`prefix of ${n} bytes parsed`);
                } catch (e) {
                    if (refused(e)) ++result.prefixesRefused;
                }
            }
            let seed = 12345;
            const random = () => (seed = (Math.imul(seed, 1103515245) + 12345) >>> 0);
            for (let i = 0; i < flips; ++i) {
                const bad = good.slice();
                bad[random() % bad.length] ^= 1 << (random() % 8);
                try {
                    const m = parseMessage(bad.buffer);
                    if (m.type === 'referenceSet') (await decodeViews(m.set)).forEach((v) => v.bitmap.close());
                } catch (e) {
                    if (refused(e)) ++result.flipsRefused;
                }
            }
            return result;
        },
    };
    window.plxTest.ready = true;
}

try {
    const client = new Client();
    if (params.has('test')) {
        client.state = 'hello';
        testHook(client);
    } else if (params.has('script')) {
        scriptHook(client);
        connect(client);
    } else {
        connect(client);
        interactive(client);
    }
} catch (e) {
    errorBox.textContent = String(e.message ?? e).split('\n')[0];
    errorBox.style.display = 'block';
}
