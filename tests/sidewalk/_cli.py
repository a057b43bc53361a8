"""Running `sidewalk` as a user does (a real subprocess), and what one bad input must give: one line, no traceback."""

import subprocess
import sys


def sidewalk(*args: str, timeout: float = 90) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sidewalk", *args], capture_output=True, text=True, timeout=timeout)


def one_line_error(p: subprocess.CompletedProcess, *needles: str) -> str:
    """Assert a nonzero exit with one stderr line holding every needle, and no traceback; return the line."""
    assert p.returncode != 0, p
    assert "Traceback" not in p.stderr and "Traceback" not in p.stdout, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]
