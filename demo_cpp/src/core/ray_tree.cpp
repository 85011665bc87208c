#include "core/ray_tree.h"

#include <cmath>
#include <utility>

namespace rt {

void RayTreeRecorder::begin_ray(RayKind kind, const ray& r, int depth) {
    RayNode node;
    node.kind = kind;
    node.depth = depth;
    node.r = r;
    if (RayNode* parent = top()) {
        parent->children.push_back(std::move(node));
        open_.push_back(&parent->children.back());
    } else {
        root_ = std::move(node);
        open_.assign(1, &root_);
    }
}

void RayTreeRecorder::hit(int sphere, float t) {
    RayNode* n = top();
    if (!n) return;
    n->sphere = sphere;
    n->t = t;
    n->point = n->r.at(t);
    // Until the tracer says which normal it shades with (a light returns before it does).
    n->normal = normalize(n->point - scene_.spheres[sphere].center);
    n->inside = dot(n->r.dir, n->normal) > 0;
    if (n->inside) n->normal = -n->normal;
    n->event = scene_.spheres[sphere].is_light() ? RayEvent::light : RayEvent::diffuse;
}

void RayTreeRecorder::surface(const vec3& normal, bool inside, bool depth_limit) {
    RayNode* n = top();
    if (!n) return;
    n->normal = normal;
    n->inside = inside;
    n->event = depth_limit ? RayEvent::depth_limit : RayEvent::diffuse;
}

void RayTreeRecorder::specular(float fresnel, bool total_internal) {
    RayNode* n = top();
    if (!n) return;
    n->event = RayEvent::specular;
    n->fresnel = fresnel;
    n->total_internal = total_internal;
}

void RayTreeRecorder::blocker(int sphere) { pending_blockers_.push_back(sphere); }

void RayTreeRecorder::light_sample(int light, const vec3& dir, float lambert, float transmission) {
    RayNode* n = top();
    if (n) n->shadows.push_back({light, dir, lambert, transmission, pending_blockers_});
    pending_blockers_.clear();
}

void RayTreeRecorder::end_ray(const color& c) {
    RayNode* n = top();
    if (!n) return;
    n->c = c;
    open_.pop_back();
}

namespace {

int surface_bits(const RayNode& node, const Scene& scene) {
    const Sphere& s = scene.spheres[static_cast<std::size_t>(node.sphere)];
    int bits = s.is_light() ? kLightHit : 0;
    if (node.kind == RayKind::camera && s.transparency > 0) bits |= kGlassHit;
    if (node.kind == RayKind::camera && s.transparency <= 0 && s.reflection > 0) bits |= kMirrorHit;
    if (node.event == RayEvent::depth_limit) bits |= kDepthLimit;
    if (node.total_internal) bits |= kTotalInternal;
    for (const ShadowSample& sample : node.shadows) {
        if (sample.lambert > 0 && sample.blockers.empty()) bits |= kDiffuseLit;
        for (const int j : sample.blockers)
            bits |= scene.spheres[static_cast<std::size_t>(j)].transparency > 0 ? kShadowGlass
                                                                                : kDiffuseShadow;
    }
    return bits;
}

bool has_nan(const vec3& v) { return std::isnan(v.x) || std::isnan(v.y) || std::isnan(v.z); }

}  // namespace

int path_bits(const RayNode& node, const Scene& scene) {
    int bits = 0;
    if (node.sphere < 0)
        bits |= node.kind == RayKind::camera ? kCameraMiss : kSecondaryMiss;
    else
        bits |= surface_bits(node, scene);
    for (const RayNode& child : node.children) {
        if (child.kind == RayKind::reflection) bits |= kMirror;
        if (child.kind == RayKind::refraction) bits |= node.inside ? kGlassLeave : kGlassEnter;
        if (child.kind == RayKind::refraction && has_nan(child.r.dir)) bits |= kTotalInternal;
        bits |= path_bits(child, scene);
    }
    return bits;
}

}  // namespace rt
