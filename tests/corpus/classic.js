// The classic Whitted program (docs/paper-model.md, `classic` mode) in JavaScript for
// Node, as a web developer writes it: plain objects {x, y, z} and small functions, Numbers
// (IEEE double) throughout, Math.pow/Math.sqrt, a Buffer written as a binary PPM with
// rounding (Math.round). Independent code written for rtval's corpus from the model's
// description; the scene (scenes/classic.json) is hard-coded. No packages.
//
//   node classic.js WIDTH HEIGHT OUT.ppm
'use strict';

const fs = require('fs');

const vec = (x, y, z) => ({ x, y, z });
const add = (a, b) => vec(a.x + b.x, a.y + b.y, a.z + b.z);
const sub = (a, b) => vec(a.x - b.x, a.y - b.y, a.z - b.z);
const scale = (a, s) => vec(a.x * s, a.y * s, a.z * s);
const mul = (a, b) => vec(a.x * b.x, a.y * b.y, a.z * b.z);
const dot = (a, b) => a.x * b.x + a.y * b.y + a.z * b.z;
function normalize(a) {
  const len = Math.sqrt(dot(a, a));
  return len > 0 ? scale(a, 1 / len) : a;
}

const BLACK = vec(0, 0, 0);
const spheres = [
  { c: vec(0, -10004, -20), r: 10000, color: vec(0.2, 0.2, 0.2), refl: 0, transp: 0, ior: 1, emit: BLACK },
  { c: vec(0, 0, -20), r: 4, color: vec(1.0, 0.32, 0.36), refl: 1, transp: 0.5, ior: 1.1, emit: BLACK },
  { c: vec(5, -1, -15), r: 2, color: vec(0.9, 0.76, 0.46), refl: 1, transp: 0, ior: 1, emit: BLACK },
  { c: vec(5, 0, -25), r: 3, color: vec(0.65, 0.77, 0.97), refl: 1, transp: 0, ior: 1, emit: BLACK },
  { c: vec(-5.5, 0, -15), r: 3, color: vec(0.9, 0.9, 0.9), refl: 1, transp: 0, ior: 1, emit: BLACK },
  { c: vec(0, 20, -30), r: 3, color: BLACK, refl: 0, transp: 0, ior: 1, emit: vec(3, 3, 3) },
];
const BACKGROUND = vec(2, 2, 2);
const MAX_DEPTH = 5;
const BIAS = 1e-4;

// Distance to the sphere, or null; the classic test gives up when the centre is behind.
function intersect(s, o, d) {
  const l = sub(s.c, o);
  const tca = dot(l, d);
  if (tca < 0) return null;
  const d2 = dot(l, l) - tca * tca;
  if (d2 > s.r * s.r) return null;
  const thc = Math.sqrt(s.r * s.r - d2);
  const t0 = tca - thc;
  return t0 < 0 ? tca + thc : t0;
}

function trace(o, d, depth) {
  let hit = null;
  let tmin = Infinity;
  for (const s of spheres) {
    const t = intersect(s, o, d);
    if (t !== null && t < tmin) {
      tmin = t;
      hit = s;
    }
  }
  if (hit === null) return BACKGROUND;
  const p = add(o, scale(d, tmin));
  let n = normalize(sub(p, hit.c));
  let inside = false;
  if (dot(d, n) > 0) {
    n = scale(n, -1);
    inside = true;
  }
  let color = BLACK;
  if ((hit.transp > 0 || hit.refl > 0) && depth < MAX_DEPTH) {
    const facing = Math.max(0, -dot(d, n));
    const fresnel = 0.1 + 0.9 * Math.pow(1 - facing, 3);
    const rdir = normalize(sub(d, scale(n, 2 * dot(d, n))));
    const reflected = trace(add(p, scale(n, BIAS)), rdir, depth + 1);
    let refracted = BLACK;
    if (hit.transp > 0) {
      const eta = inside ? hit.ior : 1 / hit.ior;
      const cosi = -dot(n, d);
      const k = 1 - eta * eta * (1 - cosi * cosi);
      const tdir = normalize(add(scale(d, eta), scale(n, eta * cosi - Math.sqrt(k))));
      refracted = trace(sub(p, scale(n, BIAS)), tdir, depth + 1);
    }
    color = mul(add(scale(reflected, fresnel), scale(refracted, (1 - fresnel) * hit.transp)), hit.color);
  } else {
    spheres.forEach((light, i) => {
      if (light.emit.x <= 0) return;
      const l = normalize(sub(light.c, p));
      const from = add(p, scale(n, BIAS));
      const blocked = spheres.some((s, j) => j !== i && intersect(s, from, l) !== null);
      if (!blocked) color = add(color, scale(mul(hit.color, light.emit), Math.max(0, dot(n, l))));
    });
  }
  return add(color, hit.emit);
}

function main() {
  const [w, h] = [Number(process.argv[2]), Number(process.argv[3])];
  const out = process.argv[4];
  if (process.argv.length !== 5 || !(w >= 1 && h >= 1)) {
    process.stderr.write('usage: node classic.js WIDTH HEIGHT OUT.ppm\n');
    process.exit(64);
  }
  const half = Math.tan(((30 / 2) * Math.PI) / 180);
  const aspect = w / h;
  const header = Buffer.from(`P6\n${w} ${h}\n255\n`, 'ascii');
  const pixels = Buffer.alloc(w * h * 3);
  const byte = (v) => (Number.isNaN(v) ? 0 : Math.round(Math.min(1, Math.max(0, v)) * 255));
  let i = 0;
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      const xx = ((2 * (x + 0.5)) / w - 1) * half * aspect;
      const yy = (1 - (2 * (y + 0.5)) / h) * half;
      const c = trace(BLACK, normalize(vec(xx, yy, -1)), 0);
      pixels[i++] = byte(c.x);
      pixels[i++] = byte(c.y);
      pixels[i++] = byte(c.z);
    }
  }
  fs.writeFileSync(out, Buffer.concat([header, pixels]));
}

main();
