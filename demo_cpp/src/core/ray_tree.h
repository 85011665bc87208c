// The ray tree of one camera ray, recorded from the scalar tracer's events (ray_recorder.h),
// and its path class: the OR of docs/diagnosis.md's event bits over the whole tree.
#pragma once

#include <optional>
#include <vector>

#include "core/ray_recorder.h"
#include "core/scene.h"

namespace rt {

// The path-class bits (fixed vocabulary, docs/diagnosis.md "Where the error lives").
enum PathBit : int {
    kCameraMiss = 1,
    kDiffuseLit = 2,
    kDiffuseShadow = 4,
    kShadowGlass = 8,
    kMirror = 16,
    kGlassEnter = 32,
    kGlassLeave = 64,
    kTotalInternal = 128,
    kDepthLimit = 256,
    kSecondaryMiss = 512,
    kLightHit = 1024,
    kGlassHit = 2048,
    kMirrorHit = 4096,
};

enum class RayEvent { miss, diffuse, specular, light, depth_limit };

struct ShadowSample {
    int light = -1;
    vec3 dir;
    float lambert = 0;
    float transmission = 1;
    std::vector<int> blockers;  // in the order the tracer tested them
};

struct RayNode {
    RayKind kind = RayKind::camera;
    int depth = 0;
    ray r;
    int sphere = -1;  // -1: missed
    float t = 0;
    point3 point;
    vec3 normal;
    bool inside = false;
    RayEvent event = RayEvent::miss;
    std::optional<float> fresnel;
    bool total_internal = false;
    std::vector<ShadowSample> shadows;
    std::vector<RayNode> children;
    color c;
};

class RayTreeRecorder final : public RayRecorder {
public:
    explicit RayTreeRecorder(const Scene& scene) : scene_(scene) {}
    void begin_ray(RayKind kind, const ray& r, int depth) override;
    void hit(int sphere, float t) override;
    void surface(const vec3& n, bool inside, bool depth_limit) override;
    void specular(float fresnel, bool total_internal) override;
    void blocker(int sphere) override;
    void light_sample(int light, const vec3& dir, float lambert, float transmission) override;
    void end_ray(const color& c) override;
    // The last camera ray's tree (complete once its end_ray came).
    const RayNode& root() const { return root_; }

private:
    RayNode* top() { return open_.empty() ? nullptr : open_.back(); }
    const Scene& scene_;
    RayNode root_;
    std::vector<RayNode*> open_;  // the rays begun and not yet ended, outermost first
    std::vector<int> pending_blockers_;
};

// The path class of a tree: the OR of the event bits of every ray in it.
int path_bits(const RayNode& node, const Scene& scene);

}  // namespace rt
