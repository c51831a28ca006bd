"""The window's camera path: the path it plays (a --replay file, one key a frame, else the
scene's own path) and the path it records (--record PATH.json, or C: a file named for the
scene and the time in --shot-dir).  No GL; messages go to `say`."""
from __future__ import annotations

from pathlib import Path
import time

from scenes import camera_path


class PathRecorder:
    def __init__(self, scene, args, say):
        self.scene = scene
        self.args = args
        self.say = say
        self.path = camera_path.load(args.replay) if args.replay else None
        self.playing = bool(args.path or self.path)
        self.frame = 0                       # the path frame the next render shows
        self.record_to = Path(args.record) if args.record else None
        self.recording: camera_path.CameraPath | None = None
        self._t0 = 0.0
        self.saved: list[str] = []

    # ---- playing -------------------------------------------------------------------------
    def path_camera(self):
        if self.path is not None:
            return self.path.camera(self.frame)
        return self.scene.camera_at(self.frame, self.args.path_frames)

    def camera(self, fly):
        """The camera of this frame: the path's while it plays, else the fly camera's."""
        return self.path_camera() if self.playing else fly.camera()

    def stop_for(self, fly) -> None:
        """The user takes the camera: playing stops where the path is (the fly camera
        starts there)."""
        if self.playing:
            self.playing = False
            fly.set_from(self.path_camera())

    def toggle_play(self, fly) -> None:
        if self.playing:
            self.stop_for(fly)
        else:
            self.playing = True

    def reset(self, fly) -> None:
        self.playing = False
        self.frame = 0
        fly.set_from(self.scene.camera)

    def advance(self) -> None:
        if self.playing:
            self.frame += 1

    # ---- recording -----------------------------------------------------------------------
    def toggle_record(self, size) -> None:
        if self.recording is None:
            self.recording = camera_path.CameraPath(scene=self.scene.name, size=size)
            self._t0 = time.perf_counter()
            self.say("recording the camera path (C stops and saves"
                     + (f" to {self.record_to})" if self.record_to else ")"))
        else:
            self.save()

    def add(self, cam) -> None:
        if self.recording is not None:
            self.recording.add(cam, time.perf_counter() - self._t0)

    def save(self) -> None:
        """Stop recording and save what was recorded (nothing: no file)."""
        rec, self.recording = self.recording, None
        if rec is None or not len(rec):
            return
        path = self.record_to or (Path(self.args.shot_dir) /
                                  f"path-{self.scene.name}-{time.strftime('%Y%m%d-%H%M%S')}.json")
        rec.save(path)
        self.saved.append(str(path))
        self.say(f"camera path: {len(rec)} keys -> {path} (replay: --replay {path})")

    # ---- what the UI shows ---------------------------------------------------------------
    def status(self) -> list[str]:
        """The HUD's first line's status words: REC, replay k/n."""
        out = []
        if self.recording is not None:
            out.append(f"REC {len(self.recording)} keys")
        if self.path is not None and self.playing:
            out.append(f"replay {self.frame % len(self.path) + 1}/{len(self.path)}")
        return out

    def lines(self) -> list[str]:
        """The panel's camera path section."""
        src = (f"replay {self.args.replay} ({len(self.path)} keys)" if self.path is not None
               else f"the scene's path ({self.args.path_frames} frames)")
        out = [f"path: {src}", "playing, frame %d" % self.frame if self.playing else "stopped"]
        if self.recording is not None:
            out.append(f"recording: {len(self.recording)} keys" + (f" -> {self.record_to}" if self.record_to else ""))
        return out + [f"saved: {p}" for p in self.saved[-2:]]
