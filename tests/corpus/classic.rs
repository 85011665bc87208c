// The classic Whitted program (docs/paper-model.md, `classic` mode) in Rust, as a Rust
// learner writes it: f64 everywhere, a Copy vector type with operator traits, an
// Option<f64> intersection, no crates (std only, built with `rustc -O`), a rounding PPM
// writer. Independent code written for rtval's corpus from the model's description; the
// scene (scenes/classic.json) is hard-coded.
//
//   classic WIDTH HEIGHT OUT.ppm
use std::env;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::ops::{Add, Mul, Neg, Sub};
use std::process::exit;

#[derive(Clone, Copy, Debug, Default)]
struct Vec3 {
    x: f64,
    y: f64,
    z: f64,
}

const fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3 { x, y, z }
}

impl Add for Vec3 {
    type Output = Vec3;
    fn add(self, o: Vec3) -> Vec3 {
        v(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl Sub for Vec3 {
    type Output = Vec3;
    fn sub(self, o: Vec3) -> Vec3 {
        v(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl Mul<f64> for Vec3 {
    type Output = Vec3;
    fn mul(self, s: f64) -> Vec3 {
        v(self.x * s, self.y * s, self.z * s)
    }
}
impl Mul for Vec3 {
    type Output = Vec3;
    fn mul(self, o: Vec3) -> Vec3 {
        v(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}
impl Neg for Vec3 {
    type Output = Vec3;
    fn neg(self) -> Vec3 {
        v(-self.x, -self.y, -self.z)
    }
}
impl Vec3 {
    fn dot(self, o: Vec3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    fn unit(self) -> Vec3 {
        let len = self.dot(self).sqrt();
        if len > 0.0 {
            self * (1.0 / len)
        } else {
            self
        }
    }
}

struct Sphere {
    centre: Vec3,
    radius: f64,
    colour: Vec3,
    reflection: f64,
    transparency: f64,
    ior: f64,
    emission: Vec3,
}

impl Sphere {
    fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<f64> {
        let l = self.centre - origin;
        let tca = l.dot(dir);
        if tca < 0.0 {
            return None;
        }
        let d2 = l.dot(l) - tca * tca;
        if d2 > self.radius * self.radius {
            return None;
        }
        let thc = (self.radius * self.radius - d2).sqrt();
        let t0 = tca - thc;
        Some(if t0 < 0.0 { tca + thc } else { t0 })
    }
}

const BLACK: Vec3 = v(0.0, 0.0, 0.0);
const BACKGROUND: Vec3 = v(2.0, 2.0, 2.0);
const MAX_DEPTH: u32 = 5;
const BIAS: f64 = 1e-4;

fn scene() -> Vec<Sphere> {
    let s = |c: Vec3, r: f64, col: Vec3, refl: f64, tr: f64, ior: f64, em: Vec3| Sphere {
        centre: c,
        radius: r,
        colour: col,
        reflection: refl,
        transparency: tr,
        ior,
        emission: em,
    };
    vec![
        s(v(0.0, -10004.0, -20.0), 10000.0, v(0.2, 0.2, 0.2), 0.0, 0.0, 1.0, BLACK),
        s(v(0.0, 0.0, -20.0), 4.0, v(1.0, 0.32, 0.36), 1.0, 0.5, 1.1, BLACK),
        s(v(5.0, -1.0, -15.0), 2.0, v(0.90, 0.76, 0.46), 1.0, 0.0, 1.0, BLACK),
        s(v(5.0, 0.0, -25.0), 3.0, v(0.65, 0.77, 0.97), 1.0, 0.0, 1.0, BLACK),
        s(v(-5.5, 0.0, -15.0), 3.0, v(0.90, 0.90, 0.90), 1.0, 0.0, 1.0, BLACK),
        s(v(0.0, 20.0, -30.0), 3.0, BLACK, 0.0, 0.0, 1.0, v(3.0, 3.0, 3.0)),
    ]
}

fn trace(world: &[Sphere], origin: Vec3, dir: Vec3, depth: u32) -> Vec3 {
    let mut nearest: Option<(f64, &Sphere)> = None;
    for s in world {
        if let Some(t) = s.intersect(origin, dir) {
            if nearest.map_or(true, |(best, _)| t < best) {
                nearest = Some((t, s));
            }
        }
    }
    let (t, s) = match nearest {
        Some(hit) => hit,
        None => return BACKGROUND,
    };
    let p = origin + dir * t;
    let mut n = (p - s.centre).unit();
    let inside = dir.dot(n) > 0.0;
    if inside {
        n = -n;
    }
    let mut c = BLACK;
    if (s.transparency > 0.0 || s.reflection > 0.0) && depth < MAX_DEPTH {
        let facing = (-dir.dot(n)).max(0.0);
        let fresnel = 0.1 + 0.9 * (1.0 - facing).powi(3);
        let r = (dir - n * (2.0 * dir.dot(n))).unit();
        let reflected = trace(world, p + n * BIAS, r, depth + 1);
        let mut refracted = BLACK;
        if s.transparency > 0.0 {
            let eta = if inside { s.ior } else { 1.0 / s.ior };
            let cosi = -n.dot(dir);
            let k = 1.0 - eta * eta * (1.0 - cosi * cosi);
            let td = (dir * eta + n * (eta * cosi - k.sqrt())).unit();
            refracted = trace(world, p - n * BIAS, td, depth + 1);
        }
        c = (reflected * fresnel + refracted * ((1.0 - fresnel) * s.transparency)) * s.colour;
    } else {
        for (i, light) in world.iter().enumerate() {
            if light.emission.x <= 0.0 {
                continue;
            }
            let l = (light.centre - p).unit();
            let shadow_origin = p + n * BIAS;
            let blocked = world
                .iter()
                .enumerate()
                .any(|(j, o)| j != i && o.intersect(shadow_origin, l).is_some());
            if !blocked {
                c = c + s.colour * light.emission * n.dot(l).max(0.0);
            }
        }
    }
    c + s.emission
}

fn byte(x: f64) -> u8 {
    if x.is_nan() {
        return 0;
    }
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

fn main() {
    let args: Vec<String> = env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: {} WIDTH HEIGHT OUT.ppm", args[0]);
        exit(64);
    }
    let w: usize = args[1].parse().unwrap_or(0);
    let h: usize = args[2].parse().unwrap_or(0);
    if w == 0 || h == 0 {
        exit(64);
    }
    let world = scene();
    let half = (30.0f64 / 2.0).to_radians().tan();
    let aspect = w as f64 / h as f64;
    let mut out = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let xx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * half * aspect;
            let yy = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * half;
            let c = trace(&world, BLACK, v(xx, yy, -1.0).unit(), 0);
            out.extend_from_slice(&[byte(c.x), byte(c.y), byte(c.z)]);
        }
    }
    let file = File::create(&args[3]).unwrap_or_else(|e| {
        eprintln!("{}: {}", args[3], e);
        exit(1);
    });
    let mut f = BufWriter::new(file);
    let ok = write!(f, "P6\n{} {}\n255\n", w, h).is_ok() && f.write_all(&out).is_ok();
    if !ok || f.flush().is_err() {
        exit(1);
    }
}
