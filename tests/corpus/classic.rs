// The classic Whitted program (docs/paper-model.md, `classic` mode) in Rust, as a Rust
// learner writes it: f64 everywhere, a Copy vector type with operator traits, an
// Option<f64> intersection, no crates (std only, built with `rustc -O`), a rounding PPM
// writer. Independent code written for rtval's corpus from the model's description; the
// scene (scenes/classic.json) is hard-coded.
//
//   classic WIDTH HEIGHT OUT.ppm [--mistake NAME[,NAME...]]
//
// The corpus's mistake variants (tests/corpus/variants.py) are run-time switches, so the
// program is built once: each NAME turns on one slip a learner makes, and NAME=VALUE sets
// one of the program's own constants:
//   fov35                    a 35 degree field of view instead of the scene's 30
//   no_aspect                x is not scaled by the aspect ratio (a square frustum)
//   exposure08               every value multiplied by 0.8 before it is written
//   bgr                      the writer puts blue first: B, G, R
//   negative_root_hit        the nearer root is returned even when it is behind the ray
//   flipped_normal           the facing test's two branches swapped: the normal points in
//   eta_inverted             ior entering glass and 1/ior leaving it
//   refraction_bias_outside  the refracted ray starts on the outside of the surface
//   fresnel_exponent         0.1 + 0.9 (1 - facing)^2 instead of the cube
//   fresnel_constants_swapped 0.9 + 0.1 (1 - facing)^3: the two constants typed the wrong way
//   shadow_first_only        the occluder loop breaks after the first sphere it tests
//   light_dir_reversed       the light direction is p - light (away from the light)
//   black_background         a miss returns black
//   depth=N, background=V    the recursion limit, a grey background V
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
    fn intersect(&self, origin: Vec3, dir: Vec3, cfg: &Config) -> Option<f64> {
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
        if cfg.has("negative_root_hit") {
            return Some(t0);
        }
        Some(if t0 < 0.0 { tca + thc } else { t0 })
    }
}

const BLACK: Vec3 = v(0.0, 0.0, 0.0);
const BIAS: f64 = 1e-4;

/// The slips this run makes (all off: the correct program) and its constants.
struct Config {
    slips: Vec<String>,
    max_depth: u32,
    background: Vec3,
}

impl Config {
    fn parse(list: &str) -> Result<Config, String> {
        let mut c = Config { slips: Vec::new(), max_depth: 5, background: v(2.0, 2.0, 2.0) };
        for item in list.split(',').filter(|s| !s.is_empty()) {
            match item.split_once('=') {
                Some(("depth", n)) => c.max_depth = n.parse().map_err(|_| format!("depth={}", n))?,
                Some(("background", g)) => {
                    let g: f64 = g.parse().map_err(|_| format!("background={}", g))?;
                    c.background = v(g, g, g);
                }
                Some(_) => return Err(format!("unknown setting {}", item)),
                None if KNOWN.contains(&item) => c.slips.push(item.to_string()),
                None => return Err(format!("unknown mistake {}", item)),
            }
        }
        Ok(c)
    }
    fn has(&self, name: &str) -> bool {
        self.slips.iter().any(|s| s == name)
    }
}

const KNOWN: [&str; 13] = [
    "fov35",
    "no_aspect",
    "exposure08",
    "bgr",
    "negative_root_hit",
    "flipped_normal",
    "eta_inverted",
    "refraction_bias_outside",
    "fresnel_exponent",
    "fresnel_constants_swapped",
    "shadow_first_only",
    "light_dir_reversed",
    "black_background",
];

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

fn trace(world: &[Sphere], cfg: &Config, origin: Vec3, dir: Vec3, depth: u32) -> Vec3 {
    let mut nearest: Option<(f64, &Sphere)> = None;
    for s in world {
        if let Some(t) = s.intersect(origin, dir, cfg) {
            if nearest.map_or(true, |(best, _)| t < best) {
                nearest = Some((t, s));
            }
        }
    }
    let (t, s) = match nearest {
        Some(hit) => hit,
        None if cfg.has("black_background") => return BLACK,
        None => return cfg.background,
    };
    let p = origin + dir * t;
    let outward = (p - s.centre).unit();
    let inside = dir.dot(outward) > 0.0;
    let n = if inside != cfg.has("flipped_normal") { -outward } else { outward };
    let mut c = BLACK;
    if (s.transparency > 0.0 || s.reflection > 0.0) && depth < cfg.max_depth {
        c = shade_mirror(world, cfg, s, p, n, inside, dir, depth);
    } else {
        for (i, light) in world.iter().enumerate() {
            if light.emission.x > 0.0 {
                c = c + s.colour * light.emission * direct(world, cfg, i, p, n);
            }
        }
    }
    c + s.emission
}

#[allow(clippy::too_many_arguments)]
fn shade_mirror(
    world: &[Sphere],
    cfg: &Config,
    s: &Sphere,
    p: Vec3,
    n: Vec3,
    inside: bool,
    dir: Vec3,
    depth: u32,
) -> Vec3 {
    let facing = (-dir.dot(n)).max(0.0);
    let fresnel = if cfg.has("fresnel_exponent") {
        0.1 + 0.9 * (1.0 - facing).powi(2)
    } else if cfg.has("fresnel_constants_swapped") {
        0.9 + 0.1 * (1.0 - facing).powi(3)
    } else {
        0.1 + 0.9 * (1.0 - facing).powi(3)
    };
    let r = (dir - n * (2.0 * dir.dot(n))).unit();
    let reflected = trace(world, cfg, p + n * BIAS, r, depth + 1);
    let mut refracted = BLACK;
    if s.transparency > 0.0 {
        let eta = if inside != cfg.has("eta_inverted") { s.ior } else { 1.0 / s.ior };
        let cosi = -n.dot(dir);
        let k = 1.0 - eta * eta * (1.0 - cosi * cosi);
        let td = (dir * eta + n * (eta * cosi - k.sqrt())).unit();
        let side = if cfg.has("refraction_bias_outside") { 1.0 } else { -1.0 };
        refracted = trace(world, cfg, p + n * (side * BIAS), td, depth + 1);
    }
    (reflected * fresnel + refracted * ((1.0 - fresnel) * s.transparency)) * s.colour
}

/// The Lambert factor of light i at p, zero when a sphere blocks its shadow ray.
fn direct(world: &[Sphere], cfg: &Config, i: usize, p: Vec3, n: Vec3) -> f64 {
    let light = &world[i];
    let l = if cfg.has("light_dir_reversed") {
        (p - light.centre).unit()
    } else {
        (light.centre - p).unit()
    };
    let shadow_origin = p + n * BIAS;
    let mut blocked = false;
    for (j, o) in world.iter().enumerate() {
        if j == i {
            continue;
        }
        if o.intersect(shadow_origin, l, cfg).is_some() {
            blocked = true;
            break;
        }
        if cfg.has("shadow_first_only") {
            break;
        }
    }
    if blocked {
        0.0
    } else {
        n.dot(l).max(0.0)
    }
}

fn byte(x: f64) -> u8 {
    if x.is_nan() {
        return 0;
    }
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

fn main() {
    let args: Vec<String> = env::args().collect();
    let list = match args.len() {
        4 => Some(""),
        6 if args[4] == "--mistake" => Some(args[5].as_str()),
        _ => None,
    };
    let cfg = match list.map(Config::parse) {
        Some(Ok(cfg)) => cfg,
        Some(Err(e)) => {
            eprintln!("{}: {}", args[0], e);
            exit(64);
        }
        None => {
            eprintln!("usage: {} WIDTH HEIGHT OUT.ppm [--mistake NAME[,NAME...]]", args[0]);
            exit(64);
        }
    };
    let w: usize = args[1].parse().unwrap_or(0);
    let h: usize = args[2].parse().unwrap_or(0);
    if w == 0 || h == 0 {
        exit(64);
    }
    let world = scene();
    let fov: f64 = if cfg.has("fov35") { 35.0 } else { 30.0 };
    let half = (fov / 2.0).to_radians().tan();
    let aspect = if cfg.has("no_aspect") { 1.0 } else { w as f64 / h as f64 };
    let exposure = if cfg.has("exposure08") { 0.8 } else { 1.0 };
    let mut out = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let xx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * half * aspect;
            let yy = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * half;
            let c = trace(&world, &cfg, BLACK, v(xx, yy, -1.0).unit(), 0) * exposure;
            let rgb = [byte(c.x), byte(c.y), byte(c.z)];
            if cfg.has("bgr") {
                out.extend_from_slice(&[rgb[2], rgb[1], rgb[0]]);
            } else {
                out.extend_from_slice(&rgb);
            }
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
