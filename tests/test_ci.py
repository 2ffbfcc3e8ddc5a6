"""The test orchestration itself: ``make test``'s two streams (.ci/test.sh, driven here by a
stand-in for make) and the GUI smoke run's choice of an X display that no other root's
Xvfb holds."""
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from repo_paths import ROOT

sys.path.insert(0, os.path.join(ROOT, "tests", "freecad"))
import gui_smoke  # noqa: E402  (stdlib only at import)

#: a stand-in for make: each target prints its name and exits with $<TARGET>_RC
FAKE_MAKE = r"""#!/usr/bin/env bash
t="$2"; v="$(echo "${t//-/_}" | tr a-z A-Z)_RC"
echo "ran $t"
if [ "$t" = test-freecad1 ]; then
  trap 'echo "$t got TERM" >> "$FAKE_TERMS"; exit 143' TERM
  : > "$FAKE_TERMS.started"
  python3 -c "import signal, sys; sys.exit(signal.getsignal(signal.SIGINT) != signal.default_int_handler)" \
    || echo "$t: SIGINT ignored"
  sleep "${FC1_SLEEP:-0}" & wait $!
fi
exit "${!v:-0}"
"""


def _run_ci(tmp_path, **env_extra):
    fake = tmp_path / "make"
    fake.write_text(FAKE_MAKE)
    fake.chmod(0o755)
    env = dict(os.environ, MAKE=str(fake), FAKE_TERMS=str(tmp_path / "terms"),
               INVRAD_TEST_LOGS=str(tmp_path / "logs"), **env_extra)
    env.pop("INVRAD_NO_FREECAD1", None)
    env.pop("INVRAD_TEST_SERIAL", None)
    return fake, env


def _script():
    return os.path.join(ROOT, ".ci", "test.sh")


P, F, N = "passed", "FAILED (status 2)", "not run"


@pytest.mark.parametrize("failing,lines", [(None, [P, P, P]),
                                           ("SETUP_RC", [F, N, P]),
                                           ("TEST_CORE_RC", [F, P, P]),
                                           ("TEST_FREECAD_RC", [P, F, P]),
                                           ("TEST_FREECAD1_RC", [P, P, F])])
def test_every_stream_runs_and_any_failure_fails_make_test(tmp_path, failing, lines):
    _, env = _run_ci(tmp_path)
    if failing:
        env[failing] = "2"
    cp = subprocess.run(["bash", _script()], env=env, capture_output=True, text=True,
                        timeout=60, preexec_fn=lambda: signal.signal(signal.SIGINT,
                                                                     signal.SIG_DFL))
    out = cp.stdout
    assert cp.returncode == (1 if failing else 0), out + cp.stderr
    host = ["setup"] + ([] if failing == "SETUP_RC" else ["test-core", "test-freecad"])
    for target in host + ["test-freecad1"]:
        assert f"ran {target}\n" in out, out
    # the root's stream: printed whole at the end, after the host's, and it kept SIGINT
    assert out.index("ran test-freecad1") > out.index(f"ran {host[-1]}\n"), out
    assert "SIGINT ignored" not in out, out
    assert [l.split("  ")[-1].strip() for l in out.splitlines()[-3:]] == lines, out
    logs = os.listdir(tmp_path / "logs")
    if failing == "TEST_FREECAD1_RC":            # a failed stream's log is kept
        assert len(logs) == 1 and logs[0] in out, (logs, out)
    else:
        assert logs == [], (logs, out)


def test_an_interrupted_make_test_ends_the_background_stream(tmp_path):
    _, env = _run_ci(tmp_path, FC1_SLEEP="60")
    p = subprocess.Popen(["bash", _script()], env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    started = tmp_path / "terms.started"
    deadline = time.time() + 30
    while not started.exists() and time.time() < deadline:
        time.sleep(0.05)
    os.killpg(p.pid, signal.SIGINT)            # what Ctrl-C sends: the foreground group
    out, _ = p.communicate(timeout=30)
    assert p.returncode == 130, out
    assert (tmp_path / "terms").read_text().strip() == "test-freecad1 got TERM", out


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="abstract sockets: Linux")
def test_the_smoke_runs_xvfb_on_a_display_no_other_root_holds():
    start = 400 + os.getpid() % 200
    first = gui_smoke.free_display(start)
    # an X server of another root (the FreeCAD 1.0 chroot) holds the abstract socket only
    held = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    held.bind(f"\0/tmp/.X11-unix/X{first}")
    held.listen(1)
    try:
        assert not os.path.exists(f"/tmp/.X{first}-lock")
        other = gui_smoke.free_display(start)
        assert other != first and other > first
    finally:
        held.close()
    assert gui_smoke.free_display(start) == first
