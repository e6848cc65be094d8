"""A real small file system for a test: a tmpfs of a few megabytes that a shell script can fill.

The tmpfs is mounted in a mount namespace of the script's own (``unshare``), so nothing outside
it sees the mount and nothing needs cleaning up: the mount goes with the script. Unprivileged, a
user namespace maps the caller to root inside (``unshare --user --map-root-user --mount``); as
root, where user namespaces are off (some containers), a mount namespace alone does. Where
neither can mount (no ``unshare``, a container without the capability), the test is skipped and
says why. What the script leaves behind for the test to check, it copies out of the tmpfs.
"""

from __future__ import annotations

import functools
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

#: ``python -c FILL FOLDER BYTES``: fill FOLDER's file system (appending to a file ``filler``) until
#: only BYTES are free (a tmpfs counts in pages, so within a page of it)
FILL = """
import os, sys
folder, leave = sys.argv[1], int(sys.argv[2])
stat = os.statvfs(folder)
with open(os.path.join(folder, "filler"), "ab") as f:
    f.write(b"x" * max(0, stat.f_bavail * stat.f_frsize - leave))
"""

_CANDIDATES = (("unshare", "--user", "--map-root-user", "--mount"), ("unshare", "--mount"))


@functools.cache
def _namespace() -> tuple[tuple[str, ...] | None, str]:
    """The first ``unshare`` prefix under which a tmpfs can be mounted, or ``None`` and why not."""
    if shutil.which("unshare") is None:
        return None, "no unshare command here (util-linux)"
    reasons = []
    with tempfile.TemporaryDirectory() as folder:
        for prefix in _CANDIDATES:
            if prefix == ("unshare", "--mount") and os.geteuid() != 0:
                continue
            probe = subprocess.run([*prefix, "mount", "-t", "tmpfs", "-o", "size=64k", "none", folder],
                                   capture_output=True, text=True, timeout=60)
            if probe.returncode == 0:
                return prefix, ""
            reasons.append(f"{' '.join(prefix)}: {probe.stderr.strip()}")
    return None, "; ".join(reasons)


def run_with_small_filesystem(script: str, mount_point: Path, size: str, env: dict[str, str],
                              timeout: float = 600) -> subprocess.CompletedProcess[str]:
    """Run the ``sh`` ``script`` with a tmpfs of ``size`` (e.g. ``"8m"``) mounted at
    ``mount_point`` (made if missing) for it alone; the test is skipped where no such mount is
    possible. ``$FS`` in the script is the mount point."""
    prefix, why_not = _namespace()
    if prefix is None:
        pytest.skip(f"cannot mount a small tmpfs here to fill up: {why_not}")
    mount_point.mkdir(parents=True, exist_ok=True)
    mount = f'mount -t tmpfs -o size={size} none "$FS" || exit 99\n'
    return subprocess.run([*prefix, "sh", "-c", mount + script], env={**env, "FS": str(mount_point)},
                          capture_output=True, text=True, timeout=timeout)
