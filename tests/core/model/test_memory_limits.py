"""The memory budget follows the limits the process really has: the address-space and data
limits (``ulimit -v``/``-d``), the cgroup v2/v1 memory limit, ``INVRAD_MEMORY_LIMIT`` and the
physical memory; a refusal names the bound that decided it."""
import os
import subprocess
import sys

import pytest

from invrad_wb.core.model import memory
from repo_paths import ROOT

GB = 1 << 30


def _write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def _mountinfo(tmp_path, lines):
    f = tmp_path / "mountinfo"
    f.write_text("".join(l + "\n" for l in lines))
    return str(f)


def test_cgroup_v2_limit_is_the_tightest_of_the_group_and_its_ancestors(tmp_path):
    fs = tmp_path / "cg2"
    _write(fs / "memory.max", "max\n")                          # the root: no limit
    _write(fs / "user.slice" / "memory.max", "4294967296\n")    # the parent: 4 GB
    _write(fs / "user.slice" / "job" / "memory.max", "max\n")   # the group itself: none
    _write(fs / "user.slice" / "job" / "memory.current", str(3 * GB) + "\n")
    _write(fs / "user.slice" / "job" / "memory.stat", f"anon {GB}\nfile {2 * GB}\n")
    cg = tmp_path / "cgroup"
    cg.write_text("0::/user.slice/job\n")
    mi = _mountinfo(tmp_path, [
        f"30 23 0:26 / {fs} rw,nosuid - cgroup2 cgroup2 rw,nsdelegate",
        "22 1 8:1 / / rw - ext4 /dev/sda1 rw"])
    lim, used, path = memory.cgroup_limit(str(cg), mi)
    # the page cache (file) can be dropped: only anonymous memory counts as used
    assert (lim, used) == (4 * GB, GB)
    assert path == str(fs / "user.slice" / "memory.max")
    (bytes_, why), = memory.cgroup_bounds(proc_cgroup=str(cg), mountinfo=mi)
    assert bytes_ == int(memory.HARD_FRACTION * 3 * GB)
    assert "cgroup memory limit of 4.0 GB" in why and "memory.max" in why


def test_cgroup_v1_limit_and_a_namespace_that_hides_the_path(tmp_path):
    fs = tmp_path / "memory"
    # inside a container the mount shows the group itself as its root: the path named in
    # /proc/self/cgroup is not under it, the mount point is the group
    _write(fs / "memory.limit_in_bytes", str(2 * GB) + "\n")
    _write(fs / "memory.usage_in_bytes", str(GB // 2) + "\n")
    cg = tmp_path / "cgroup"
    cg.write_text("12:pids:/\n4:memory:/docker/abc123\n1:name=systemd:/docker/abc123\n")
    mi = _mountinfo(tmp_path, [
        f"35 31 0:32 /docker/abc123 {fs} rw,relatime - cgroup cgroup rw,memory"])
    assert memory.cgroup_limit(str(cg), mi) == (2 * GB, GB // 2,
                                                str(fs / "memory.limit_in_bytes"))


def test_no_cgroup_limit_gives_no_bound(tmp_path):
    fs = tmp_path / "memory"
    # cgroup v1's "unlimited": 2^63 rounded down to a page
    _write(fs / "memory.limit_in_bytes", "9223372036854771712\n")
    cg = tmp_path / "cgroup"
    cg.write_text("4:memory:/\n0::/\n")
    mi = _mountinfo(tmp_path, [f"35 31 0:32 / {fs} rw - cgroup cgroup rw,memory"])
    assert memory.cgroup_limit(str(cg), mi) is None
    assert memory.cgroup_limit(str(tmp_path / "absent"), mi) is None


def test_rlimit_bounds_leave_room_for_what_is_mapped():
    (b, why), = memory.rlimit_bounds({"AS": 4 * GB}, used=(GB, GB // 4))
    assert b == int(memory.HARD_FRACTION * 3 * GB) and "ulimit -v" in why
    (b, why), = memory.rlimit_bounds({"DATA": GB}, used=(3 * GB, GB // 4))
    assert b == int(memory.HARD_FRACTION * 3 * GB // 4) and "ulimit -d" in why
    assert memory.rlimit_bounds({"AS": 2 * GB}, used=(3 * GB, 0))[0][0] == 0


def test_the_budget_is_the_smallest_bound_and_the_message_names_it(monkeypatch):
    monkeypatch.setenv(memory.ENV, "100G")
    monkeypatch.setattr(memory, "rlimit_bounds", lambda: [(GB, "the address-space limit"
                                                              " (ulimit -v)")])
    monkeypatch.setattr(memory, "cgroup_bounds", lambda: [(2 * GB, "cgroup")])
    assert memory.budget() == (GB, "the address-space limit (ulimit -v)")
    with pytest.raises(memory.MemoryLimitError, match=r"over the limit of 1.0 GB \(the"
                                                      r" address-space limit \(ulimit -v\)"):
        memory.require(1.5 * GB, "a big thing")
    monkeypatch.setenv(memory.ENV, "500M")
    assert memory.budget()[1] == f"{memory.ENV}=500M"


def test_locate_under_an_address_space_limit_refuses_at_once(tmp_path):
    """``ulimit -v`` below the vote maps' estimate: one line naming ``ulimit -v``, exit 2,
    before any vote map is made (it used to run 23-34 s into a MemoryError, exit 70)."""
    import resource
    scene = tmp_path / "room.ply"
    subprocess.run([sys.executable, "-m", "invrad_wb", "example", "one_ceiling", "-o",
                    str(scene), "--cell", "0.5", "--backend", "numpy"], cwd=ROOT, check=True,
                   capture_output=True)
    out = tmp_path / "r.json"
    limit = 3 * GB

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    env = {k: v for k, v in os.environ.items() if k != memory.ENV}
    # numpy backend: an NVIDIA OpenCL driver maps about 3 GB of address space when its
    # context is made (seen on an H200), which would leave this limit nothing to estimate
    # against (invrad then refuses the votes per m^2 instead, also in one line)
    p = subprocess.run([sys.executable, "-m", "invrad_wb", "locate", str(scene), "--flux",
                        "3000", "-o", str(out), "--resolution", "0.0025", "--backend", "numpy"],
                       cwd=ROOT, env=env,
                       preexec_fn=cap, capture_output=True, text=True, timeout=120)
    err = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == 2, p.stderr
    assert len(err) == 1 and err[0].startswith("invrad: error: room 0's vote maps"), p.stderr
    assert "ulimit -v" in err[0] and "--resolution" in err[0]
    assert "Traceback" not in p.stderr and not out.exists()
