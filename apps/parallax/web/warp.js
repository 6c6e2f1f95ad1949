// McMillan's warp of reference views in WebGL2 (Mark, Bishop, McMillan, "Post-Rendering 3D
// Warping"; the equation and its derivation in libs/warp/include/plx/warp/equation.h).
//
// Every source pixel is one vertex (gl_VertexID -> x, y; no vertex buffers), displaced in the
// vertex shader by
//   x' = (a x + b y + c delta + k) / D,  y' = (d x + e y + f delta + l) / D,
//   D  = g x + h y + i delta + m,
// with the twelve coefficients computed here exactly as warpCoefficients() does (double
// arithmetic, one rounding to f32), and drawn as a point sized by the paper's derivative splat
// (the axis-aligned sx x sy rectangle of splat.h, cut out of the point's square in the fragment
// shader with the native kernel's half-open pixel-centre rule). Points, not a torn triangle mesh:
// the derivative splat is the paper's kernel and the native client's default, so the two frames
// can be compared pixel for pixel, and it needs no neighbour topology or tear threshold. Depth is
// the destination's 1/w (delta / D), z-tested, so all faces of a set composite correctly.

const f32 = Math.fround;
// kMaxSplatSize (splat.h): the largest splat side in destination pixels.
export const MAX_SPLAT = 6;
// A guard band of destination pixels around the canvas: GL drops a point whose centre leaves
// the viewport, the native splat is cut at the image edge instead; 4 > MAX_SPLAT / 2 + 0.5.
const GUARD = 4;
// The renderer's clear colour (WarpOptions::clearColor): what no splat covers.
export const CLEAR_COLOR = [40, 44, 52];

// 3-vectors and column-major 3x3 matrices (m[c * 3 + r], glm's [column][row]).
const sub3 = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
// glm::normalize in f32: v * inversesqrt(dot(v, v)), inversesqrt(x) = 1 / sqrt(x), each op
// rounded to f32 (sqrt and division are correctly rounded in both).
const normalizeF = (v) => {
    const s = f32(1 / f32(Math.sqrt(f32(f32(f32(v[0] * v[0]) + f32(v[1] * v[1])) + f32(v[2] * v[2])))));
    return [f32(v[0] * s), f32(v[1] * s), f32(v[2] * s)];
};
const crossF = (a, b) => [f32(f32(a[1] * b[2]) - f32(a[2] * b[1])),
                          f32(f32(a[2] * b[0]) - f32(a[0] * b[2])),
                          f32(f32(a[0] * b[1]) - f32(a[1] * b[0]))];

function mul3(a, b) {
    const m = new Array(9);
    for (let c = 0; c < 3; ++c) {
        for (let r = 0; r < 3; ++r) {
            m[c * 3 + r] = a[r] * b[c * 3] + a[3 + r] * b[c * 3 + 1] + a[6 + r] * b[c * 3 + 2];
        }
    }
    return m;
}
const mulVec3 = (a, v) => [0, 1, 2].map((r) => a[r] * v[0] + a[3 + r] * v[1] + a[6 + r] * v[2]);

// The inverse by the adjugate: columns (a b c), (d e f), (g h i).
function inverse3(m) {
    const [a, b, c, d, e, f, g, h, i] = m;
    const det = a * (e * i - h * f) - d * (b * i - h * c) + g * (b * f - e * c);
    const s = 1 / det;
    return [
        (e * i - h * f) * s, -(b * i - h * c) * s, (b * f - e * c) * s,
        -(d * i - g * f) * s, (a * i - g * c) * s, -(a * f - d * c) * s,
        (d * h - g * e) * s, -(a * h - g * b) * s, (a * e - d * b) * s,
    ];
}

// A pinhole camera as Camera::create builds it (f32 frame and matrices), kept as the two
// matrices rayFromPixel needs: the clip matrix's first three columns and the view rotation.
// desc: {eye, target, up, fovY (degrees), near, far, width, height, shift: [x, y] pixels}.
export function makeCamera(desc) {
    const eye = desc.eye.map(f32), target = desc.target.map(f32);
    // The camera's frame (Camera::Camera), then glm::lookAt(eye, target, up): rows s, u, -f.
    const f = normalizeF(sub3(target, eye).map(f32));
    const right = normalizeF(crossF(f, desc.up.map(f32)));
    const up = crossF(right, f);
    const s = normalizeF(crossF(f, up));
    const u = crossF(s, f);
    const viewRot = [s[0], u[0], -f[0], s[1], u[1], -f[1], s[2], u[2], -f[2]];
    // glm::perspective (right-handed, clip z in -1..1), then the principal point shift.
    const aspect = f32(desc.width / desc.height);
    // plx::radians: degrees * (kPi / 180.0f) in f32.
    const radians = f32(desc.fovY * f32(f32(Math.PI) / 180));
    const tanHalf = f32(Math.tan(f32(radians / 2)));
    const clip = [  // columns 0..2 of the 4x4 clip matrix, 4 rows each
        f32(1 / f32(aspect * tanHalf)), 0, 0, 0,
        0, f32(1 / tanHalf), 0, 0,
        f32(-2 * f32(desc.shift[0]) / desc.width), f32(2 * f32(desc.shift[1]) / desc.height),
        f32(-f32(desc.far + desc.near) / f32(desc.far - desc.near)), -1,
    ];
    return {eye, width: desc.width, height: desc.height, clip, viewRot};
}

// P of equation.h: world-space ray (forward component 1) of pixel position (u, v, 1).
export function rayFromPixel(cam) {
    const halfW = 0.5 * cam.width, halfH = 0.5 * cam.height;
    const pixelFromView = new Array(9);
    for (let c = 0; c < 3; ++c) {
        const col = cam.clip.slice(c * 4, c * 4 + 4);
        pixelFromView[c * 3] = halfW * (col[0] + col[3]);
        pixelFromView[c * 3 + 1] = halfH * (col[3] - col[1]);
        pixelFromView[c * 3 + 2] = col[3];
    }
    return inverse3(mul3(pixelFromView, cam.viewRot));
}

// warpCoefficients(source, destination) of equation.h, for source pixel indices.
export function warpCoefficients(source, destination) {
    const destFromRay = inverse3(rayFromPixel(destination));
    const m = mul3(destFromRay, rayFromPixel(source));
    const t = mulVec3(destFromRay, sub3(source.eye, destination.eye));
    const at = (c, r) => m[c * 3 + r];
    return {
        a: f32(at(0, 0)), b: f32(at(1, 0)), c: f32(t[0]), k: f32(at(2, 0) + 0.5 * (at(0, 0) + at(1, 0))),
        d: f32(at(0, 1)), e: f32(at(1, 1)), f: f32(t[1]), l: f32(at(2, 1) + 0.5 * (at(0, 1) + at(1, 1))),
        g: f32(at(0, 2)), h: f32(at(1, 2)), i: f32(t[2]), m: f32(at(2, 2) + 0.5 * (at(0, 2) + at(1, 2))),
    };
}

const VERTEX_SHADER = `#version 300 es
precision highp float;
precision highp int;
uniform highp sampler2D uDisparity;  // R32F, 1/w per source pixel
uniform lowp sampler2D uColor;       // RGBA8
uniform int uWidth, uHeight;         // source size
uniform vec4 uX;                     // a b c k
uniform vec4 uY;                     // d e f l
uniform vec4 uD;                     // g h i m
uniform vec2 uDest;                  // destination size, pixels
uniform float uGuard;
uniform float uMaxSplat;
uniform vec3 uClear;  // the colour of empty pixels (1/w = 0), as the native warp draws them
flat out vec4 vColor;
flat out vec2 vCentre;  // warped position (x', y'), destination pixels, y down
flat out vec2 vHalf;    // half the splat's sides

float disparityAt(int x, int y) { return texelFetch(uDisparity, ivec2(x, y), 0).r; }

// neighbourDerivative (splat.h): the smaller one-sided difference; one side at the border.
float derivative(bool hasBefore, float before, float here, bool hasAfter, float after) {
    if (hasBefore && hasAfter) {
        float back = here - before, fwd = after - here;
        return abs(fwd) < abs(back) ? fwd : back;
    }
    if (hasAfter) return after - here;
    if (hasBefore) return here - before;
    return 0.0;
}

void main() {
    int x = gl_VertexID % uWidth, y = gl_VertexID / uWidth;
    float delta = disparityAt(x, y);
    float fx = float(x), fy = float(y);
    // equation.h's row terms, then the per-pixel terms, in the native kernel's order.
    float nx = ((uX.y * fy + uX.w) + uX.x * fx) + uX.z * delta;
    float ny = ((uY.y * fy + uY.w) + uY.x * fx) + uY.z * delta;
    float nd = ((uD.y * fy + uD.w) + uD.x * fx) + uD.z * delta;
    if (!(nd > 0.0)) {  // behind the destination: not drawn
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        gl_PointSize = 1.0;
        return;
    }
    float r = 1.0 / nd;
    float xp = nx * r, yp = ny * r, dd = delta * r;
    float ddx = derivative(x > 0, x > 0 ? disparityAt(x - 1, y) : 0.0, delta,
                           x + 1 < uWidth, x + 1 < uWidth ? disparityAt(x + 1, y) : 0.0);
    float ddy = derivative(y > 0, y > 0 ? disparityAt(x, y - 1) : 0.0, delta,
                           y + 1 < uHeight, y + 1 < uHeight ? disparityAt(x, y + 1) : 0.0);
    // The paper's derivative splat (derivativeSplatSize), clamped to [1, kMaxSplatSize].
    float cx = uX.z - uD.z * xp, cy = uY.z - uD.z * yp;
    float sx = abs((ddx * cx + (uX.x - uD.x * xp)) * r) + abs((ddy * cx + (uX.y - uD.y * xp)) * r);
    float sy = abs((ddx * cy + (uY.x - uD.x * yp)) * r) + abs((ddy * cy + (uY.y - uD.y * yp)) * r);
    vHalf = 0.5 * clamp(vec2(sx, sy), 1.0, uMaxSplat);
    vCentre = vec2(xp, yp);
    vColor = delta > 0.0 ? texelFetch(uColor, ivec2(x, y), 0) : vec4(uClear, 1.0);
    // The viewport spans the canvas plus the guard band, so window x = x', window y = H - y'.
    vec2 span = uDest + 2.0 * uGuard;
    vec2 ndc = vec2(2.0 * (xp + uGuard) / span.x - 1.0, 1.0 - 2.0 * (yp + uGuard) / span.y);
    // Window depth dd / (dd + 1), increasing with the destination's 1/w and tested GREATER into a
    // 32-bit float depth buffer cleared to 0 (nearer wins, as the native z-buffer's larger 1/w):
    // f32 resolves neighbouring splats' 1/w where a 16- or 24-bit buffer left ties that the
    // draw order broke. 1/w = 0 (the background at infinity) is drawn a hair above the clear.
    float z = 2.0 * (1e-7 + 0.9999 * (dd / (dd + 1.0))) - 1.0;
    gl_Position = vec4(ndc, z, 1.0);
    gl_PointSize = 2.0 * max(vHalf.x, vHalf.y) + 1.0;
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
uniform vec2 uDest;
flat in vec4 vColor;
flat in vec2 vCentre;
flat in vec2 vHalf;
out vec4 outColor;
void main() {
    // The native splat's pixels: centres in [x' - hx, x' + hx) x [y' - hy, y' + hy).
    vec2 centre = vec2(gl_FragCoord.x, uDest.y - gl_FragCoord.y);
    vec2 o = centre - vCentre;
    if (o.x < -vHalf.x || o.x >= vHalf.x || o.y < -vHalf.y || o.y >= vHalf.y) discard;
    outColor = vec4(vColor.rgb, 1.0);
}`;

function compile(gl, type, source) {
    const s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(s)}`);
    return s;
}

// Warps decoded reference sets into a WebGL2 canvas.
export class GlWarper {
    constructor(canvas) {
        const gl = canvas.getContext('webgl2', {antialias: false, depth: false, alpha: false});
        if (!gl) throw new Error('WebGL2 is not available');
        this.gl = gl;
        this.canvas = canvas;
        const program = gl.createProgram();
        gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX_SHADER));
        gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
        gl.linkProgram(program);
        if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`link: ${gl.getProgramInfoLog(program)}`);
        this.program = program;
        this.u = {};
        for (const n of ['uDisparity', 'uColor', 'uWidth', 'uHeight', 'uX', 'uY', 'uD', 'uDest',
                         'uGuard', 'uMaxSplat', 'uClear']) {
            this.u[n] = gl.getUniformLocation(program, n);
        }
        this.vao = gl.createVertexArray();
        this.views = [];
        this.target = null;  // {w, h, framebuffer, color, depth}
    }

    // The offscreen target of the destination's size: RGBA8 colour, 32-bit float depth.
    bindTarget(w, h) {
        const gl = this.gl;
        if (!this.target || this.target.w !== w || this.target.h !== h) {
            if (this.target) {
                gl.deleteFramebuffer(this.target.framebuffer);
                gl.deleteRenderbuffer(this.target.color);
                gl.deleteRenderbuffer(this.target.depth);
            }
            const framebuffer = gl.createFramebuffer(), color = gl.createRenderbuffer(),
                  depth = gl.createRenderbuffer();
            gl.bindRenderbuffer(gl.RENDERBUFFER, color);
            gl.renderbufferStorage(gl.RENDERBUFFER, gl.RGBA8, w, h);
            gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
            gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT32F, w, h);
            gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
            gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.RENDERBUFFER, color);
            gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
            if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) {
                throw new Error('WebGL2: no RGBA8 + DEPTH_COMPONENT32F framebuffer');
            }
            this.target = {w, h, framebuffer, color, depth};
        }
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.target.framebuffer);
    }

    // Uploads a decoded set: per view its camera, colour bitmap and disparity. Replaces the last.
    upload(set, decoded) {
        const gl = this.gl;
        this.release();
        this.views = set.views.map((view, i) => {
            const color = gl.createTexture();
            gl.bindTexture(gl.TEXTURE_2D, color);
            gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
            gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
            gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
            gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, decoded[i].bitmap);
            setNearest(gl);
            const disparity = gl.createTexture();
            gl.bindTexture(gl.TEXTURE_2D, disparity);
            gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
            gl.texImage2D(gl.TEXTURE_2D, 0, gl.R32F, view.width, view.height, 0, gl.RED, gl.FLOAT,
                          decoded[i].disparity);
            setNearest(gl);
            decoded[i].bitmap.close();
            return {camera: makeCamera(view.camera), width: view.width, height: view.height, color,
                    disparity};
        });
    }

    release() {
        for (const v of this.views) {
            this.gl.deleteTexture(v.color);
            this.gl.deleteTexture(v.disparity);
        }
        this.views = [];
    }

    // Draws the uploaded set warped to `destination` (a makeCamera camera of the canvas' size).
    // maxSplat 1 gives the point kernel (one pixel per source pixel), for tests.
    render(destination, maxSplat = MAX_SPLAT) {
        const gl = this.gl;
        const w = destination.width, h = destination.height;
        this.bindTarget(w, h);
        gl.viewport(-GUARD, -GUARD, w + 2 * GUARD, h + 2 * GUARD);
        gl.clearColor(CLEAR_COLOR[0] / 255, CLEAR_COLOR[1] / 255, CLEAR_COLOR[2] / 255, 1);
        gl.clearDepth(0);
        gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
        gl.enable(gl.DEPTH_TEST);
        gl.depthFunc(gl.GREATER);
        gl.useProgram(this.program);
        gl.bindVertexArray(this.vao);
        gl.uniform2f(this.u.uDest, w, h);
        gl.uniform1f(this.u.uGuard, GUARD);
        gl.uniform1f(this.u.uMaxSplat, maxSplat);
        gl.uniform3f(this.u.uClear, CLEAR_COLOR[0] / 255, CLEAR_COLOR[1] / 255, CLEAR_COLOR[2] / 255);
        gl.uniform1i(this.u.uDisparity, 0);
        gl.uniform1i(this.u.uColor, 1);
        for (const v of this.views) {
            const c = warpCoefficients(v.camera, destination);
            gl.uniform4f(this.u.uX, c.a, c.b, c.c, c.k);
            gl.uniform4f(this.u.uY, c.d, c.e, c.f, c.l);
            gl.uniform4f(this.u.uD, c.g, c.h, c.i, c.m);
            gl.uniform1i(this.u.uWidth, v.width);
            gl.uniform1i(this.u.uHeight, v.height);
            gl.activeTexture(gl.TEXTURE0);
            gl.bindTexture(gl.TEXTURE_2D, v.disparity);
            gl.activeTexture(gl.TEXTURE1);
            gl.bindTexture(gl.TEXTURE_2D, v.color);
            gl.drawArrays(gl.POINTS, 0, v.width * v.height);
        }
        // Shown on the canvas; readPixels reads the offscreen target.
        gl.bindFramebuffer(gl.READ_FRAMEBUFFER, this.target.framebuffer);
        gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, null);
        gl.blitFramebuffer(0, 0, w, h, 0, 0, w, h, gl.COLOR_BUFFER_BIT, gl.NEAREST);
    }

    // The canvas' pixels, RGBA rows top to bottom.
    readPixels(w, h) {
        const gl = this.gl;
        const flipped = new Uint8Array(w * h * 4), out = new Uint8Array(w * h * 4);
        gl.bindFramebuffer(gl.READ_FRAMEBUFFER, this.target.framebuffer);
        gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, flipped);
        for (let y = 0; y < h; ++y) out.set(flipped.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
        return out;
    }
}

function setNearest(gl) {
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
}

// The display camera of a head pose {eye, forward, up} for a canvas of w x h.
export function displayCamera(pose, w, h, fovY = 60) {
    const target = [pose.eye[0] + pose.forward[0], pose.eye[1] + pose.forward[1],
                    pose.eye[2] + pose.forward[2]];
    return makeCamera({eye: pose.eye, target, up: pose.up, fovY, near: 0.05, far: 1000,
                       width: w, height: h, shift: [0, 0]});
}
