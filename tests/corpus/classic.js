// The classic Whitted program (docs/paper-model.md, `classic` mode) in JavaScript for
// Node, as a web developer writes it: plain objects {x, y, z} and small functions, Numbers
// (IEEE double) throughout, Math.pow/Math.sqrt, a Buffer written as a binary PPM with
// rounding (Math.round). Independent code written for rtval's corpus from the model's
// description; the scene (scenes/classic.json) is hard-coded. No packages.
//
//   node classic.js WIDTH HEIGHT OUT.ppm [--mistake NAME[,NAME...]]
//
// The corpus's mistake variants (tests/corpus/variants.py) are run-time switches: each NAME
// turns on one slip, NAME=VALUE sets one of the program's constants:
//   bgr                      the writer puts blue first: B, G, R
//   gamma2                   Math.sqrt(v) written ("gamma 2" encoding) instead of v
//   tan_full_fov             tan(fov) instead of tan(fov / 2)
//   ray_dir_unnormalized     camera rays (x, y, -1) as they are, not normalised
//   reflect_sign             d + 2 (d.n) n instead of d - 2 (d.n) n
//   reflect_half             d - (d.n) n: the factor 2 forgotten
//   no_inside_flip           the normal is not turned round inside a sphere
//   inside_test_reversed     the inside test written d.n < 0: outside hits taken as inside
//   k_eta_unsquared          1 - eta (1 - cos^2) under the refraction's square root
//   cosi_sign                cos i taken as +n.d (an rtv1 C port's)
//   watt_refraction          the root divided by eta^2 in the direction ("Watt's formula")
//   clamp_each_trace         every colour trace() returns capped at 1 (before the mix)
//   fresnel_weights_swapped  reflection weighted by 1 - fresnel and refraction by fresnel
//   fresnel_exponent         0.1 + 0.9 (1 - facing)^2 instead of the cube
//   refraction_unweighted    the refracted colour not multiplied by the transparency
//   light_blocks_itself      the light is not skipped in its own shadow test
//   light_dir_from_normal    the light direction light - n, the normal where the point belongs
//   no_shadows               the shadow test is left out
//   ior=V                    the glass's index
//   glass_blue=V             the glass's colour's blue (ggerholm's Java port types 0.26)
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
const KNOWN = [
  'bgr', 'gamma2', 'tan_full_fov', 'ray_dir_unnormalized', 'reflect_sign', 'reflect_half',
  'no_inside_flip', 'inside_test_reversed', 'k_eta_unsquared', 'fresnel_weights_swapped', 'fresnel_exponent',
  'refraction_unweighted', 'light_blocks_itself', 'light_dir_from_normal', 'no_shadows',
  'cosi_sign', 'watt_refraction', 'clamp_each_trace',
];
const slips = new Set();

// Reads "name,name,ior=V,glass_blue=V"; returns an error message or null.
function setMistakes(list) {
  for (const item of list.split(',').filter((s) => s !== '')) {
    const [key, value] = item.split('=');
    if (key === 'ior' && value !== undefined && Number(value) > 0) {
      spheres.filter((s) => s.transp > 0).forEach((s) => { s.ior = Number(value); });
    } else if (key === 'glass_blue' && value !== undefined && Number(value) >= 0) {
      spheres.filter((s) => s.transp > 0).forEach((s) => { s.color = vec(s.color.x, s.color.y, Number(value)); });
    } else if (value === undefined && KNOWN.includes(key)) {
      slips.add(key);
    } else {
      return `unknown mistake ${item}`;
    }
  }
  return null;
}

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
  const c = traceRay(o, d, depth);
  if (!slips.has('clamp_each_trace')) return c;
  return vec(Math.min(1, c.x), Math.min(1, c.y), Math.min(1, c.z));
}

function traceRay(o, d, depth) {
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
  const away = slips.has('inside_test_reversed') ? dot(d, n) < 0 : dot(d, n) > 0;
  if (away) {
    if (!slips.has('no_inside_flip')) n = scale(n, -1);
    inside = true;
  }
  let color = BLACK;
  if ((hit.transp > 0 || hit.refl > 0) && depth < MAX_DEPTH) {
    color = shadeMirror(hit, p, n, d, inside, depth);
  } else {
    spheres.forEach((light, i) => {
      if (light.emit.x <= 0) return;
      const l = normalize(sub(light.c, slips.has('light_dir_from_normal') ? n : p));
      if (!inShadow(i, add(p, scale(n, BIAS)), l)) {
        color = add(color, scale(mul(hit.color, light.emit), Math.max(0, dot(n, l))));
      }
    });
  }
  return add(color, hit.emit);
}

function reflectDir(d, n) {
  if (slips.has('reflect_sign')) return normalize(add(d, scale(n, 2 * dot(d, n))));
  if (slips.has('reflect_half')) return normalize(sub(d, scale(n, dot(d, n))));
  return normalize(sub(d, scale(n, 2 * dot(d, n))));
}

function shadeMirror(hit, p, n, d, inside, depth) {
  const facing = Math.max(0, -dot(d, n));
  const power = slips.has('fresnel_exponent') ? 2 : 3;
  const fresnel = 0.1 + 0.9 * Math.pow(1 - facing, power);
  const reflected = trace(add(p, scale(n, BIAS)), reflectDir(d, n), depth + 1);
  let refracted = BLACK;
  if (hit.transp > 0) {
    const eta = inside ? hit.ior : 1 / hit.ior;
    const cosi = slips.has('cosi_sign') ? dot(n, d) : -dot(n, d);
    const k = 1 - (slips.has('k_eta_unsquared') ? eta : eta * eta) * (1 - cosi * cosi);
    const root = slips.has('watt_refraction') ? Math.sqrt(k) / (eta * eta) : Math.sqrt(k);
    const tdir = normalize(add(scale(d, eta), scale(n, eta * cosi - root)));
    refracted = trace(sub(p, scale(n, BIAS)), tdir, depth + 1);
  }
  const kr = slips.has('fresnel_weights_swapped') ? 1 - fresnel : fresnel;
  const kt = slips.has('refraction_unweighted') ? 1 - kr : (1 - kr) * hit.transp;
  return mul(add(scale(reflected, kr), scale(refracted, kt)), hit.color);
}

// Whether a sphere other than light i lies along the shadow ray.
function inShadow(i, from, l) {
  if (slips.has('no_shadows')) return false;
  const itself = slips.has('light_blocks_itself');
  return spheres.some((s, j) => (itself || j !== i) && intersect(s, from, l) !== null);
}

function main() {
  const args = process.argv.slice(2);
  if (args.length === 5 && args[3] === '--mistake') {
    const error = setMistakes(args.pop());
    if (error) {
      process.stderr.write(`${error}\n`);
      process.exit(64);
    }
    args.pop();
  }
  const [w, h] = [Number(args[0]), Number(args[1])];
  const out = args[2];
  if (args.length !== 3 || !(w >= 1 && h >= 1)) {
    process.stderr.write('usage: node classic.js WIDTH HEIGHT OUT.ppm [--mistake NAME[,NAME...]]\n');
    process.exit(64);
  }
  const fov = (30 * Math.PI) / 180;
  const half = Math.tan(slips.has('tan_full_fov') ? fov : fov / 2);
  const aspect = w / h;
  const header = Buffer.from(`P6\n${w} ${h}\n255\n`, 'ascii');
  const pixels = Buffer.alloc(w * h * 3);
  const encode = slips.has('gamma2') ? Math.sqrt : (v) => v;
  const byte = (v) => (Number.isNaN(v) ? 0 : Math.round(encode(Math.min(1, Math.max(0, v))) * 255));
  const order = slips.has('bgr') ? ['z', 'y', 'x'] : ['x', 'y', 'z'];
  let i = 0;
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      const xx = ((2 * (x + 0.5)) / w - 1) * half * aspect;
      const yy = (1 - (2 * (y + 0.5)) / h) * half;
      const dir = vec(xx, yy, -1);
      const c = trace(BLACK, slips.has('ray_dir_unnormalized') ? dir : normalize(dir), 0);
      for (const k of order) pixels[i++] = byte(c[k]);
    }
  }
  fs.writeFileSync(out, Buffer.concat([header, pixels]));
}

main();
