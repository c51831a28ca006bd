"""Scenes: builtin procedural scenes, JSON scene files and glTF 2.0 files (no OpenGL, no
culling)."""
from .builtin import BUILTIN_SCENES, BUILTIN_VARIANTS
from .gltf import load_gltf
from .loader import SceneError, load_scene, scene_from_dict
from .model import LIGHT_DTYPE, Camera, Fog, Mesh, Scene, make_lights

__all__ = ["load_scene", "scene_from_dict", "load_gltf", "SceneError", "BUILTIN_SCENES", "BUILTIN_VARIANTS", "Scene",
           "Camera", "Fog", "Mesh", "LIGHT_DTYPE", "make_lights"]
