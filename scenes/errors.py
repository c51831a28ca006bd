"""What every scene source shares: the one error type and the size limits of a scene."""

MAX_LIGHTS = 4_194_304


class SceneError(ValueError):
    """A scene that cannot be built or loaded; the message is one line naming file and field."""
