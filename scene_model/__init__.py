"""The scene model shared by every Python part of rtval: rtval-scene/1 files
(docs/scene-format.md) loaded, validated and typed. mitsuba_ref exports it to Mitsuba; compare
reads it for the effect masks; demo_cpp has its C++ twin (scene_loader.cpp)."""

from scene_model.scene import Camera, Scene, SceneError, Sphere, Vec3, load_scene, parse_scene

__all__ = ["Camera", "Scene", "SceneError", "Sphere", "Vec3", "load_scene", "parse_scene"]
