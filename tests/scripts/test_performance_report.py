"""bench/report.py (docs/performance.md): it writes the page from
bench/results.json, and refuses to overwrite a page holding lines it would
not write itself (rows and sections measured by hand with other commands),
naming how many; --force replaces it. Needs neither the module nor the data
(matplotlib optional: the plot is written only where it is installed)."""
import os
import subprocess
import sys

SOURCE_DIR = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
REPORT = os.path.join(SOURCE_DIR, "bench", "report.py")


def run(tmp_path, *extra):
    return subprocess.run([sys.executable, REPORT, "--md", str(tmp_path / "p.md"),
                           "--png", str(tmp_path / "p.png"), *extra],
                          capture_output=True, text=True)


def test_hand_measured_lines_are_not_overwritten_without_force(tmp_path):
    md = tmp_path / "p.md"
    first = run(tmp_path)
    assert first.returncode == 0, first.stderr
    generated = md.read_text()
    assert generated.startswith("# Performance\n")
    assert run(tmp_path).returncode == 0  # its own page: rewritten
    hand = generated + "\n| a row measured by hand (`some command`, 2026-12-07) | 1 | | |\n"
    md.write_text(hand)
    refused = run(tmp_path)
    assert refused.returncode == 1
    assert "holds 1 lines the generated page lacks" in refused.stderr, refused.stderr
    assert "a row measured by hand" in refused.stderr
    assert md.read_text() == hand  # nothing lost
    forced = run(tmp_path, "--force")
    assert forced.returncode == 0, forced.stderr
    assert md.read_text() == generated
