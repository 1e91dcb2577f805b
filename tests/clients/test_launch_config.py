"""``launch.simulated_config`` writes what ``daemon/config.py`` reads. Clients may not import
the daemon, so launch writes plain TOML; here the daemon's own loader reads it back, and
every option must land in the typed field it means (a renamed key fails here, not in a
spawned daemon's log)."""

from __future__ import annotations

from pathlib import Path

from cyborg.clients.launch import simulated_config
from cyborg.daemon.config import load


def _load(tmp_path: Path, text: str):
    path = tmp_path / "cyborgd.toml"
    path.write_text(text)
    return load(path)


def test_every_option_lands_in_its_field(tmp_path: Path) -> None:
    cfg = _load(
        tmp_path,
        simulated_config(
            "life",
            tmp_path / "archive",
            listen=["tcp/127.0.0.1:0"],
            connect=["tcp/127.0.0.1:7447"],
            time_scale=8,
            ptu_query="&baud=0",
            seed=5,
            frame_rate=25.0,
            survey={"rows": 1, "cols": 2, "settings": ["top_n=2"], "simulate_approach": True},
            zenoh={"shared_memory": True},
            sections={"site": {"heading": 90.0}, "record": {"enabled": False}},
        ),
    )
    assert (cfg.rig, cfg.archive) == ("life", tmp_path / "archive")
    assert cfg.ptu == "pty://?model=D46-17&time_scale=8&baud=0"
    assert cfg.camera.url == "sim://outcrop?seed=5&hfov=30"
    z = cfg.zenoh
    assert (z.mode, z.listen, z.connect, z.shared_memory) == (
        "peer",
        ("tcp/127.0.0.1:0",),
        ("tcp/127.0.0.1:7447",),
        True,
    )
    assert cfg.frames.rate == 25.0
    s = cfg.survey
    assert (s.rows, s.cols, s.settings, s.simulate_approach) == (1, 2, ("top_n=2",), True)
    assert cfg.site.heading == 90.0 and cfg.record.enabled is False


def test_a_client_of_a_router_and_a_real_camera(tmp_path: Path) -> None:
    real = {"camera": {"url": "v4l2://0", "hfov": 42.0}}
    cfg = _load(
        tmp_path,
        simulated_config("rig2", tmp_path / "a", connect=["tcp/127.0.0.1:7447"], sections=real),
    )
    assert cfg.zenoh.mode == "client" and cfg.zenoh.listen == ()
    assert (cfg.camera.url, cfg.camera.hfov) == ("v4l2://0", 42.0)
    assert cfg.ptu == "pty://?model=D46-17&time_scale=1"
