"""Issue 45 item 1 (docs/edges.md round 8): the reports list the parametric intensities
beside the walls (metrics.json had them; report.md and report.html did not). Fast: the canned
check and the time domain's doubles."""

from __future__ import annotations

from tests import time_doubles as td

BD = "systems/bilateral-duffing"


def test_the_check_report_lists_the_parametric_intensities(canned_check, tmp_path):
    import vifpk

    out = tmp_path / "rep"
    vifpk.check(BD, out=out, models=("exact",))
    md, page = (out / "report.md").read_text(), (out / "report.html").read_text()
    assert "| parametric.stiffness | 0.002 |" in md
    assert "parametric.stiffness" in page and "system.lower_wall" in page
    assert "| system.upper_wall |" in md


def test_the_time_reports_list_the_parametric_intensities(monkeypatch, tmp_path):
    from vifpk.harness.cli.app import main

    td.install(monkeypatch)
    out = tmp_path / "p"
    assert main(["passage", BD, "--threshold", "0.5", "--start", "0.1", "--model", "exact",
                 "--quiet", "--paths", "256", "--out", str(out)]) == 0
    assert "| parametric.stiffness | 0.002 |" in (out / "report.md").read_text()
    assert "parametric.stiffness" in (out / "report.html").read_text()


def test_a_scene_without_parametric_noise_has_no_such_rows():
    from vifpk.harness.outputs.report import scene_rows

    import vifpk

    rows = scene_rows(vifpk.scene("paper-base"))
    assert not any(f.startswith("parametric.") for f, _ in rows)
    assert ["noise.D", str(vifpk.scene("paper-base").noise.D)] in rows
