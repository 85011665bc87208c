// vec3: the one small vector type of the demo. Float32 on purpose: the paper's
// program and its GLSL twin both compute in single precision.
#pragma once

#include <cmath>

namespace rt {

struct vec3 {
    float x = 0, y = 0, z = 0;

    constexpr vec3() = default;
    constexpr vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
    constexpr explicit vec3(float s) : x(s), y(s), z(s) {}

    constexpr float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    constexpr vec3 operator-() const { return {-x, -y, -z}; }
    vec3& operator+=(const vec3& v) {
        x += v.x;
        y += v.y;
        z += v.z;
        return *this;
    }
    vec3& operator*=(const vec3& v) {
        x *= v.x;
        y *= v.y;
        z *= v.z;
        return *this;
    }
    vec3& operator*=(float s) {
        x *= s;
        y *= s;
        z *= s;
        return *this;
    }
};

using point3 = vec3;
using color = vec3;

constexpr vec3 operator+(const vec3& a, const vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
constexpr vec3 operator-(const vec3& a, const vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
constexpr vec3 operator*(const vec3& a, const vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
constexpr vec3 operator*(const vec3& a, float s) { return {a.x * s, a.y * s, a.z * s}; }
constexpr vec3 operator*(float s, const vec3& a) { return a * s; }
constexpr vec3 operator/(const vec3& a, float s) { return {a.x / s, a.y / s, a.z / s}; }

constexpr float dot(const vec3& a, const vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr vec3 cross(const vec3& a, const vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(const vec3& v) { return std::sqrt(dot(v, v)); }
// Precondition: v is not the zero vector.
inline vec3 normalize(const vec3& v) { return v / length(v); }
inline float max_abs_component(const vec3& v) {
    return std::fmax(std::fabs(v.x), std::fmax(std::fabs(v.y), std::fabs(v.z)));
}

}  // namespace rt
