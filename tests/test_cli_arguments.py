"""Bad command-line arguments get argparse's usage error (exit 2), checked where they are
declared (``type=``, ``choices=``), never by hand after parsing."""

from __future__ import annotations

import pytest

from mavhelm.cli import build_parser, main
from mavhelm.sitl.models import DEFAULT_MODEL, MODEL_NAMES

BAD = [
    ("run", "m.moos", "--connect", "tcp:nohost"),
    ("check", "--listen", "-1"),
    ("check", "--listen", "nan"),
    ("request", "--connect", "tcp:h:1", "--job", "J", "--client", "C", "--target", "1:2:3", "T"),
    ("request", "--connect", "tcp:h:1", "--job", "J", "--client", "C", "--source", "1:300", "T"),
    ("request", "--connect", "tcp:h:1", "--job", "J", "--client", "C", "--wait", "0", "T"),
    ("request", "--connect", "tcp:h:1", "--job", "J", "--client", "C", "T", "Location"),
    ("request", "--connect", "udp:h", "--job", "J", "--client", "C", "T"),
    ("demo", "--model", "boat"),
    ("demo", "--vehicle", "rover"),
    ("sim", "--variant", "skid"),
    ("sim", "--speedup", "-2"),
    ("sim", "--param", "WP_SPEED=fast"),
    ("instruments", "--truth", "tcp:127.0.0.1:5762", "--rate", "0"),
    ("instruments", "--truth", "tcp:127.0.0.1:5762", "--water-depth", "inf"),
    ("instruments", "--truth", "tcp:127.0.0.1:5762", "--model", "boat"),
]


@pytest.mark.parametrize("argv", BAD, ids=lambda a: " ".join(a))
def test_a_bad_argument_is_a_usage_error(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(list(argv))
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: mavhelm")
    assert f"mavhelm {argv[0]}: error:" in err or "mavhelm: error: unrecognized arguments" in err


def test_a_request_needs_a_task_or_close(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["request", "--connect", "tcp:127.0.0.1:9", "--job", "J", "--client", "C"])
    assert exc.value.code == 2
    assert "mavhelm request: error: give a task type" in capsys.readouterr().err


def test_good_arguments_arrive_typed():
    p = build_parser()
    a = p.parse_args(["request", "--connect", "tcp:h:1", "--job", "J", "--client", "C",
                      "--target", "1:191", "--wait", "2.5", "GoToWayPoint", "Location=10,20"])
    assert (a.target, a.source, a.wait) == ((1, 191), (1, 25), 2.5)
    assert a.properties == [("Location", "10,20")]
    assert p.parse_args(["demo"]).model == DEFAULT_MODEL == "mavhelm-boat"
    assert p.parse_args(["sim", "--model", "rover"]).model == "rover"
    assert set(MODEL_NAMES) >= {"motorboat", "rover", "mavhelm-boat", "mavhelm-rover-skid"}
    assert p.parse_args(["instruments", "--truth", "tcp:127.0.0.1:5762"]).model == "motorboat"
