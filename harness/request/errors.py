"""The one error of the request layer: bad input found before any work."""

from __future__ import annotations

from vifpk.core.scene import BadInput


class InputError(BadInput):
    """Bad input found before any work (an option, a combination, a cost): one line naming
    it. Not a SceneError: the scene file itself may be fine."""
