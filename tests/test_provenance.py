"""The provenance block: keys, run-id format, scene hash (against hashlib), overrides in order."""

import hashlib
import re
from datetime import UTC, datetime

from vifpk.core import provenance


def test_block_has_every_key(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_bytes(b"name = 'x'\n")
    now = datetime(2026, 11, 23, 11, 35, 12, tzinfo=UTC)
    p = provenance.collect(argv=["vifpk", "check", str(scene)], scene_path=scene,
                           overrides=["system.r=0.9", "system.r=0.95"], now=now)
    assert set(p) == {"run_id", "created", "vifpk", "git", "versions", "command", "scene",
                      "overrides"}
    assert re.fullmatch(r"20261123T113512Z-[0-9a-f]{6}", p["run_id"])
    assert p["created"] == "2026-11-23T11:35:12Z"
    assert p["scene"]["sha256"] == hashlib.sha256(b"name = 'x'\n").hexdigest()
    assert p["overrides"] == ["system.r=0.9", "system.r=0.95"]
    assert p["command"].startswith("vifpk check ")
    assert {"python", "numpy"} <= set(p["versions"])


def test_run_ids_differ_within_one_second():
    now = datetime(2026, 11, 23, tzinfo=UTC)
    ids = {provenance.new_run_id(now) for _ in range(50)}
    assert len(ids) == 50  # 6 hex digits: P(a collision among 50) = 50 * 49 / 2 / 16**6 ~ 7e-5


def test_scene_file_finds_shipped_scenes_where_load_scene_does(tmp_path, monkeypatch):
    """Issue 19 bug 3: a shipped scene's file is found where ``load_scene`` reads it (package
    data ``vifpk.scenes``, e.g. in a wheel install), not in a ``scenes/`` beside the
    package. Here the shipped scenes are moved to a folder only the loader knows."""
    import vifpk.core.shipped as shipped_mod
    from vifpk.core.scene import load_scene

    (tmp_path / "hard").mkdir()
    body = b"name = 'only-here'\n"
    (tmp_path / "only-here.toml").write_bytes(body)
    (tmp_path / "hard" / "deep.toml").write_bytes(body)
    monkeypatch.setattr(shipped_mod, "shipped_scenes", lambda: tmp_path)  # where it lives
    monkeypatch.chdir(tmp_path / "hard")  # no only-here.toml in the working directory
    for name in ("only-here", "hard/deep"):
        assert load_scene(name).name == "only-here"
        found = provenance.scene_file(name)
        assert found is not None, name
        assert provenance.collect(scene_path=found)["scene"]["sha256"] == \
            hashlib.sha256(body).hexdigest()
    assert provenance.scene_file("nowhere") is None
    assert provenance.scene_file("only-here.toml") is None  # a path, and not here
