// The classic Whitted program (docs/paper-model.md, `classic` mode) in Go, as a Go
// programmer writes it: float64 throughout, a value-type vector with methods, a slice of
// spheres, math.Pow/math.Sqrt, a truncating PPM writer through bufio. Independent code
// written for rtval's corpus from the model's description; the scene (scenes/classic.json)
// is hard-coded. Standard library only.
//
//	classic WIDTH HEIGHT OUT.ppm
package main

import (
	"bufio"
	"fmt"
	"math"
	"os"
	"strconv"
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
	if t < 0 {
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

const (
	maxDepth = 5
	bias     = 1e-4
	fovY     = 30.0
)

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
	n := p.Sub(s.Centre).Norm()
	inside := false
	if d.Dot(n) > 0 {
		n, inside = n.Scale(-1), true
	}
	var c Vec
	if (s.Transparency > 0 || s.Reflection > 0) && depth < maxDepth {
		facing := math.Max(0, -d.Dot(n))
		fresnel := 0.1 + 0.9*math.Pow(1-facing, 3)
		r := d.Sub(n.Scale(2 * d.Dot(n))).Norm()
		reflected := trace(p.Add(n.Scale(bias)), r, depth+1)
		var refracted Vec
		if s.Transparency > 0 {
			eta := 1 / s.IOR
			if inside {
				eta = s.IOR
			}
			cosi := -n.Dot(d)
			k := 1 - eta*eta*(1-cosi*cosi)
			t := d.Scale(eta).Add(n.Scale(eta*cosi - math.Sqrt(k))).Norm()
			refracted = trace(p.Sub(n.Scale(bias)), t, depth+1)
		}
		c = reflected.Scale(fresnel).Add(refracted.Scale((1 - fresnel) * s.Transparency)).Mul(s.Colour)
	} else {
		for i := range world {
			light := &world[i]
			if light.Emission.X <= 0 {
				continue
			}
			l := light.Centre.Sub(p).Norm()
			from := p.Add(n.Scale(bias))
			visible := 1.0
			for j := range world {
				if j == i {
					continue
				}
				if _, ok := world[j].Hit(from, l); ok {
					visible = 0
					break
				}
			}
			c = c.Add(s.Colour.Mul(light.Emission).Scale(visible * math.Max(0, n.Dot(l))))
		}
	}
	return c.Add(s.Emission)
}

func toByte(v float64) byte {
	if math.IsNaN(v) || v <= 0 {
		return 0
	}
	return byte(math.Min(1, v) * 255)
}

func main() {
	if len(os.Args) != 4 {
		fmt.Fprintf(os.Stderr, "usage: %s WIDTH HEIGHT OUT.ppm\n", os.Args[0])
		os.Exit(64)
	}
	w, err1 := strconv.Atoi(os.Args[1])
	h, err2 := strconv.Atoi(os.Args[2])
	if err1 != nil || err2 != nil || w < 1 || h < 1 {
		os.Exit(64)
	}
	half := math.Tan(fovY / 2 * math.Pi / 180)
	aspect := float64(w) / float64(h)
	pix := make([]byte, 0, w*h*3)
	for y := 0; y < h; y++ {
		for x := 0; x < w; x++ {
			xx := (2*(float64(x)+0.5)/float64(w) - 1) * half * aspect
			yy := (1 - 2*(float64(y)+0.5)/float64(h)) * half
			c := trace(Vec{}, Vec{xx, yy, -1}.Norm(), 0)
			pix = append(pix, toByte(c.X), toByte(c.Y), toByte(c.Z))
		}
	}
	f, err := os.Create(os.Args[3])
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
