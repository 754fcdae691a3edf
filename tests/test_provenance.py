"""The provenance block: keys, run-id format, scene hash (against hashlib), overrides in order."""

import hashlib
import re
from datetime import UTC, datetime

from harness import provenance


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
