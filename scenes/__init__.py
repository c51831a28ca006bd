"""Scenes: builtin procedural scenes and JSON scene files (no OpenGL, no culling)."""
from .builtin import BUILTIN_SCENES
from .loader import SceneError, load_scene, scene_from_dict
from .model import LIGHT_DTYPE, Camera, Mesh, Scene, make_lights

__all__ = ["load_scene", "scene_from_dict", "SceneError", "BUILTIN_SCENES", "Scene", "Camera",
           "Mesh", "LIGHT_DTYPE", "make_lights"]
