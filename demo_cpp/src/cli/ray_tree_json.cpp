#include "cli/ray_tree_json.h"

#include <cmath>

namespace rt {
namespace {

using json = nlohmann::ordered_json;

// A float as JSON; NaN and infinities (a NaN refraction's direction) become null.
json number(float v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json triple(const vec3& v) { return json::array({number(v.x), number(v.y), number(v.z)}); }

const char* kind_name(RayKind k) {
    switch (k) {
        case RayKind::camera:
            return "camera";
        case RayKind::reflection:
            return "reflection";
        case RayKind::refraction:
            return "refraction";
    }
    return "camera";
}

const char* event_name(RayEvent e) {
    switch (e) {
        case RayEvent::miss:
            return "miss";
        case RayEvent::diffuse:
            return "diffuse";
        case RayEvent::specular:
            return "specular";
        case RayEvent::light:
            return "light";
        case RayEvent::depth_limit:
            return "depth_limit";
    }
    return "miss";
}

json shadow_json(const ShadowSample& s) {
    const json blocked = s.blockers.empty() ? json(nullptr) : json(s.blockers.front());
    return {{"light", s.light},
            {"direction", triple(s.dir)},
            {"lambert", number(s.lambert)},
            {"blocked_by", blocked},
            {"transmission", triple(color(s.transmission))}};
}

json hit_json(const RayNode& n, const Scene& scene) {
    if (n.sphere < 0) return nullptr;
    return {{"sphere", n.sphere},
            {"name", scene.spheres[static_cast<std::size_t>(n.sphere)].name},
            {"t", number(n.t)},
            {"point", triple(n.point)},
            {"normal", triple(n.normal)},
            {"inside", n.inside}};
}

json node_json(const RayNode& n, const Scene& scene) {
    json shadows = json::array();
    for (const ShadowSample& s : n.shadows) shadows.push_back(shadow_json(s));
    json children = json::array();
    for (const RayNode& c : n.children) children.push_back(node_json(c, scene));
    return {{"kind", kind_name(n.kind)},
            {"depth", n.depth},
            {"origin", triple(n.r.origin)},
            {"direction", triple(n.r.dir)},
            {"hit", hit_json(n, scene)},
            {"event", event_name(n.event)},
            {"fresnel", n.fresnel ? number(*n.fresnel) : json(nullptr)},
            {"shadow_rays", shadows},
            {"children", children},
            {"color", triple(n.c)}};
}

}  // namespace

json pixel_json(const PixelTrace& trace, const Scene& scene, int x, int y) {
    return {{"x", x},
            {"y", y},
            {"color", triple(trace.pixel)},
            {"path", trace.path},
            {"tree", node_json(trace.tree, scene)}};
}

}  // namespace rt
