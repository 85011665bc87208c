// The classic Whitted program (docs/paper-model.md, `classic` mode) in Go, as a Go
// programmer writes it: float64 throughout, a value-type vector with methods, a slice of
// spheres, math.Pow/math.Sqrt, a truncating PPM writer through bufio. Independent code
// written for rtval's corpus from the model's description; the scene (scenes/classic.json)
// is hard-coded. Standard library only.
//
//	classic WIDTH HEIGHT OUT.ppm [--mistake NAME[,NAME...]]
//
// The corpus's mistake variants (tests/corpus/variants.py) are run-time switches, so the
// program is built once: each NAME turns on one slip, NAME=VALUE sets one of its constants:
//
//	rows_bottom_up          the writer starts at the bottom row
//	no_clamp                byte(int(v * 255)) without min(1, v): bright values wrap round
//	fov_on_x                the 30 degrees taken as the horizontal field of view
//	pixel_corners           camera rays through (x, y) instead of the pixel centre
//	y_by_width              the row's coordinate divided by the width (a copy-paste typo)
//	near_root_only          a sphere whose nearer root is behind the ray is missed
//	normal_not_normalized   the normal p - centre is used as it is
//	reflection_untinted     the reflected colour is not multiplied by the surface colour
//	eta_leaving             1/ior at both crossings (leaving glass too)
//	eta_one_leaving         eta = 1 when leaving glass: the ray leaves undeflected
//	fresnel_facing_sign     the facing ratio +d.n instead of -d.n
//	fresnel_facing_clamped  max(0, +d.n): the sign lost inside the clamp, so the facing ratio is
//	                        0 at every outside hit (a Fresnel weight of 1, no refraction)
//	shadow_dir_unnormalized the shadow ray's direction light - p is not normalised
//	lambert_unclamped       n.l without max(0, .)
//	glass_no_shadow         the shadow loop skips transparent spheres
//	eta_ior_both            eta = ior at both crossings (the inside test left out)
//	normal_precedence       the normal normalize(p - c/r): (p - c)/r without its brackets
//	cosi_unflipped          cos i from the normal before the inside flip (wrong leaving glass)
//	far_root                the sphere test returns the far root tca + thc
//	depth=N, bias=V         the recursion limit and the offset of secondary rays
//	light_y=V               the light's centre at height V (CAPBenchmarks' RT kernel: 30)
package main

import (
	"bufio"
	"fmt"
	"math"
	"os"
	"strconv"
	"strings"
)

type Vec struct{ X, Y, Z float64 }

func (a Vec) Add(b Vec) Vec       { return Vec{a.X + b.X, a.Y + b.Y, a.Z + b.Z} }
func (a Vec) Sub(b Vec) Vec       { return Vec{a.X - b.X, a.Y - b.Y, a.Z - b.Z} }
func (a Vec) Scale(s float64) Vec { return Vec{a.X * s, a.Y * s, a.Z * s} }
func (a Vec) Mul(b Vec) Vec       { return Vec{a.X * b.X, a.Y * b.Y, a.Z * b.Z} }
func (a Vec) Dot(b Vec) float64   { return a.X*b.X + a.Y*b.Y + a.Z*b.Z }
func (a Vec) Norm() Vec {
	l := math.Sqrt(a.Dot(a))
	if l > 0 {
		return a.Scale(1 / l)
	}
	return a
}

type Sphere struct {
	Centre                        Vec
	Radius                        float64
	Colour                        Vec
	Reflection, Transparency, IOR float64
	Emission                      Vec
}

// Hit returns the distance along a unit direction, with the classic tca < 0 early-out.
func (s *Sphere) Hit(o, d Vec) (float64, bool) {
	l := s.Centre.Sub(o)
	tca := l.Dot(d)
	if tca < 0 {
		return 0, false
	}
	d2 := l.Dot(l) - tca*tca
	if d2 > s.Radius*s.Radius {
		return 0, false
	}
	thc := math.Sqrt(s.Radius*s.Radius - d2)
	t := tca - thc
	if slips["far_root"] {
		t = tca + thc
	}
	if t < 0 {
		if slips["near_root_only"] {
			return 0, false
		}
		t = tca + thc
	}
	return t, true
}

var world = []Sphere{
	{Vec{0, -10004, -20}, 10000, Vec{0.2, 0.2, 0.2}, 0, 0, 1, Vec{}},
	{Vec{0, 0, -20}, 4, Vec{1.0, 0.32, 0.36}, 1, 0.5, 1.1, Vec{}},
	{Vec{5, -1, -15}, 2, Vec{0.90, 0.76, 0.46}, 1, 0, 1, Vec{}},
	{Vec{5, 0, -25}, 3, Vec{0.65, 0.77, 0.97}, 1, 0, 1, Vec{}},
	{Vec{-5.5, 0, -15}, 3, Vec{0.90, 0.90, 0.90}, 1, 0, 1, Vec{}},
	{Vec{0, 20, -30}, 3, Vec{}, 0, 0, 1, Vec{3, 3, 3}},
}

const fovY = 30.0

var (
	maxDepth = 5
	bias     = 1e-4
	slips    = map[string]bool{}
)

var known = []string{
	"rows_bottom_up", "no_clamp", "fov_on_x", "pixel_corners", "y_by_width", "near_root_only",
	"normal_not_normalized", "reflection_untinted", "eta_leaving", "eta_one_leaving", "fresnel_facing_sign", "fresnel_facing_clamped",
	"shadow_dir_unnormalized", "lambert_unclamped", "glass_no_shadow", "eta_ior_both",
	"normal_precedence", "cosi_unflipped", "far_root",
}

// setMistakes reads "name,name,depth=N,bias=V,light_y=V".
func setMistakes(list string) error {
	for _, item := range strings.Split(list, ",") {
		key, value, valued := strings.Cut(item, "=")
		var err error
		switch {
		case item == "":
		case valued && key == "depth":
			maxDepth, err = strconv.Atoi(value)
		case valued && key == "bias":
			bias, err = strconv.ParseFloat(value, 64)
		case valued && key == "light_y":
			world[len(world)-1].Centre.Y, err = strconv.ParseFloat(value, 64)
		case !valued && contains(known, item):
			slips[item] = true
		default:
			return fmt.Errorf("unknown mistake %q", item)
		}
		if err != nil {
			return fmt.Errorf("%s: %v", item, err)
		}
	}
	return nil
}

func contains(list []string, s string) bool {
	for _, x := range list {
		if x == s {
			return true
		}
	}
	return false
}

var background = Vec{2, 2, 2}

func trace(o, d Vec, depth int) Vec {
	var s *Sphere
	tNear := math.Inf(1)
	for i := range world {
		if t, ok := world[i].Hit(o, d); ok && t < tNear {
			tNear, s = t, &world[i]
		}
	}
	if s == nil {
		return background
	}
	p := o.Add(d.Scale(tNear))
	n := p.Sub(s.Centre)
	if slips["normal_precedence"] {
		n = p.Sub(s.Centre.Scale(1 / s.Radius))
	}
	if !slips["normal_not_normalized"] {
		n = n.Norm()
	}
	inside := false
	if d.Dot(n) > 0 {
		n, inside = n.Scale(-1), true
	}
	var c Vec
	if (s.Transparency > 0 || s.Reflection > 0) && depth < maxDepth {
		c = mirror(s, p, n, d, inside, depth)
	} else {
		for i := range world {
			if world[i].Emission.X > 0 {
				c = c.Add(s.Colour.Mul(world[i].Emission).Scale(lit(i, p, n)))
			}
		}
	}
	return c.Add(s.Emission)
}

func mirror(s *Sphere, p, n, d Vec, inside bool, depth int) Vec {
	facing := math.Max(0, -d.Dot(n))
	if slips["fresnel_facing_sign"] {
		facing = d.Dot(n)
	} else if slips["fresnel_facing_clamped"] {
		facing = math.Max(0, d.Dot(n))
	}
	fresnel := 0.1 + 0.9*math.Pow(1-facing, 3)
	r := d.Sub(n.Scale(2 * d.Dot(n))).Norm()
	reflected := trace(p.Add(n.Scale(bias)), r, depth+1)
	var refracted Vec
	if s.Transparency > 0 {
		eta := 1 / s.IOR
		if inside && !slips["eta_leaving"] {
			eta = s.IOR
		}
		if inside && slips["eta_one_leaving"] {
			eta = 1
		}
		if slips["eta_ior_both"] {
			eta = s.IOR
		}
		cosi := -n.Dot(d)
		if inside && slips["cosi_unflipped"] {
			cosi = -cosi
		}
		k := 1 - eta*eta*(1-cosi*cosi)
		t := d.Scale(eta).Add(n.Scale(eta*cosi - math.Sqrt(k))).Norm()
		refracted = trace(p.Sub(n.Scale(bias)), t, depth+1)
	}
	if slips["reflection_untinted"] {
		return reflected.Scale(fresnel).Add(refracted.Scale((1 - fresnel) * s.Transparency).Mul(s.Colour))
	}
	return reflected.Scale(fresnel).Add(refracted.Scale((1 - fresnel) * s.Transparency)).Mul(s.Colour)
}

// lit is light i's Lambert factor at p, 0 where another sphere blocks the shadow ray.
func lit(i int, p, n Vec) float64 {
	toLight := world[i].Centre.Sub(p)
	l := toLight.Norm()
	shadowDir := l
	if slips["shadow_dir_unnormalized"] {
		shadowDir = toLight
	}
	from := p.Add(n.Scale(bias))
	for j := range world {
		if j == i || (slips["glass_no_shadow"] && world[j].Transparency > 0) {
			continue
		}
		if _, ok := world[j].Hit(from, shadowDir); ok {
			return 0
		}
	}
	if slips["lambert_unclamped"] {
		return n.Dot(l)
	}
	return math.Max(0, n.Dot(l))
}

func toByte(v float64) byte {
	if math.IsNaN(v) || v <= 0 {
		return 0
	}
	if slips["no_clamp"] {
		return byte(int(v * 255))
	}
	return byte(math.Min(1, v) * 255)
}

// ray is the camera ray through pixel (x, y).
func ray(x, y, w, h int) Vec {
	half := math.Tan(fovY / 2 * math.Pi / 180)
	aspect := float64(w) / float64(h)
	sx, sy := half*aspect, half
	if slips["fov_on_x"] {
		sx, sy = half, half/aspect
	}
	centre := 0.5
	if slips["pixel_corners"] {
		centre = 0
	}
	rows := float64(h)
	if slips["y_by_width"] {
		rows = float64(w)
	}
	xx := (2*(float64(x)+centre)/float64(w) - 1) * sx
	yy := (1 - 2*(float64(y)+centre)/rows) * sy
	return Vec{xx, yy, -1}.Norm()
}

func main() {
	args := os.Args
	if len(args) == 6 && args[4] == "--mistake" {
		if err := setMistakes(args[5]); err != nil {
			fmt.Fprintln(os.Stderr, err)
			os.Exit(64)
		}
		args = args[:4]
	}
	if len(args) != 4 {
		fmt.Fprintf(os.Stderr, "usage: %s WIDTH HEIGHT OUT.ppm [--mistake NAME[,NAME...]]\n", args[0])
		os.Exit(64)
	}
	w, err1 := strconv.Atoi(args[1])
	h, err2 := strconv.Atoi(args[2])
	if err1 != nil || err2 != nil || w < 1 || h < 1 {
		os.Exit(64)
	}
	pix := make([]byte, 0, w*h*3)
	for row := 0; row < h; row++ {
		y := row
		if slips["rows_bottom_up"] {
			y = h - 1 - row
		}
		for x := 0; x < w; x++ {
			c := trace(Vec{}, ray(x, y, w, h), 0)
			pix = append(pix, toByte(c.X), toByte(c.Y), toByte(c.Z))
		}
	}
	f, err := os.Create(args[3])
	if err != nil {
		fmt.Fprintln(os.Stderr, err)
		os.Exit(1)
	}
	bw := bufio.NewWriter(f)
	fmt.Fprintf(bw, "P6\n%d %d\n255\n", w, h)
	bw.Write(pix)
	if bw.Flush() != nil || f.Close() != nil {
		os.Exit(1)
	}
}
