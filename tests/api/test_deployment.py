"""docker/ stays consistent with the CLI and the settings (Docker itself cannot run here): the
image's command parses with `waamflow serve`'s own parser, every WAAMFLOW_* variable the files set
is a setting the server reads, ports and addresses agree across Dockerfile, compose file, Caddyfile
and nginx.conf, the Dask services use flags `dask` has, and the image's command with the compose
file's environment starts a server that listens on 0.0.0.0 and requires the token (without a token
it refuses to start)."""

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import yaml
from fastapi.testclient import TestClient

from waamflow import cli
from waamflow.settings import Settings

DOCKER = Path(__file__).resolve().parents[2] / "docker"
SETTINGS_ENV = {f"WAAMFLOW_{name.upper()}" for name in Settings.model_fields}
TOKEN = "compose-token-0123456789abcdef"


def dockerfile() -> dict:
    text = (DOCKER / "Dockerfile").read_text()
    text = re.sub(r"\\\n", " ", text)  # continuation lines
    out: dict = {"env": {}, "expose": [], "copy_to": []}
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("CMD "):
            out["cmd"] = json.loads(line[4:])
        elif line.startswith("ENV "):
            for item in shlex.split(line[4:]):
                k, _, v = item.partition("=")
                out["env"][k] = v
        elif line.startswith("EXPOSE "):
            out["expose"] += [int(p) for p in line[7:].split()]
        elif line.startswith("HEALTHCHECK "):
            out["health"] = line
        elif line.startswith("COPY "):
            out["copy_to"].append(line.split()[-1])
    return out


def compose() -> dict:
    return yaml.safe_load((DOCKER / "compose.yml").read_text())


def _variables(text: str) -> set[str]:
    return set(re.findall(r"\b(WAAMFLOW_[A-Z_]+)\b", text))


def test_image_command_parses_with_the_cli():
    d = dockerfile()
    assert d["cmd"][0] == "waamflow"
    args = cli.build_parser().parse_args(d["cmd"][1:])  # an unknown flag would exit 2 here
    assert args.func is cli.cmd_serve
    assert args.host == "0.0.0.0" and d["expose"] == [args.port]
    assert f"127.0.0.1:{args.port}/api/health" in d["health"]
    assert args.data == "/data" == d["env"]["WAAMFLOW_DATA_DIR"]  # also `waamflow backup`'s default there
    assert args.graphs == d["env"]["WAAMFLOW_GRAPHS_DIR"]
    assert d["env"]["WAAMFLOW_STATIC_DIR"] in d["copy_to"]  # the GUI is copied where the server looks
    waamflow_env = {k for k in d["env"] if k.startswith("WAAMFLOW_")}
    assert waamflow_env <= SETTINGS_ENV, waamflow_env - SETTINGS_ENV
    # every variable the Dockerfile's comments mention is read too
    assert _variables((DOCKER / "Dockerfile").read_text()) <= SETTINGS_ENV


def test_compose_file_matches_settings_and_services():
    c = compose()
    svc = c["services"]
    app, port = svc["waamflow"], cli.build_parser().parse_args(dockerfile()["cmd"][1:]).port
    env = app["environment"]
    text = (DOCKER / "compose.yml").read_text()
    ours = _variables(text) - set(svc["caddy"]["environment"])  # WAAMFLOW_HOSTNAME is Caddy's
    assert ours <= SETTINGS_ENV, ours - SETTINGS_ENV  # also the commented ones
    # the token comes from a compose secret, mounted where WAAMFLOW_TOKEN_FILE points
    (secret,) = app["secrets"]
    assert env["WAAMFLOW_TOKEN_FILE"] == f"/run/secrets/{secret}"
    assert c["secrets"][secret]["file"] == "./tokens.txt" and "docker/tokens.txt" in text
    assert "docker/tokens.txt" in (DOCKER.parent / ".gitignore").read_text()  # never committed
    assert "docker/tokens.txt" in (DOCKER.parent / ".dockerignore").read_text()  # nor sent to a build
    # only the TLS proxy publishes ports; waamflow is reached on the compose network
    assert "ports" not in app and svc["caddy"]["ports"] == ["80:80", "443:443"]
    # the server's scheduler is the dask-scheduler service, and the workers join it
    sched = env["WAAMFLOW_SCHEDULER"]
    m = re.fullmatch(r"tcp://([a-z-]+):(\d+)", sched)
    assert m and m.group(1) in svc
    sched_cmd = svc[m.group(1)]["command"]
    assert sched_cmd[:2] == ["dask", "scheduler"] and sched_cmd[sched_cmd.index("--port") + 1] == m.group(2)
    worker_cmd = svc["dask-worker"]["command"]
    assert worker_cmd[:3] == ["dask", "worker", sched]
    # the workers read the run's files (uploads, parameter XML) at the same paths as the server
    data_volume = next(v for v in app["volumes"] if v.split(":")[1] == "/data")
    assert any(v.startswith(data_volume.split(":")[0] + ":/data") for v in svc["dask-worker"]["volumes"])
    for name in ("dask-scheduler", "dask-worker"):
        assert svc[name]["image"] == app["image"]  # the app's image: same waamflow and dependencies
    # Caddy forwards to the server's port, unbuffered (Server-Sent Events)
    caddy = (DOCKER / "Caddyfile").read_text()
    assert f"reverse_proxy waamflow:{port}" in caddy and "flush_interval -1" in caddy
    assert "./Caddyfile:/etc/caddy/Caddyfile:ro" in svc["caddy"]["volumes"]
    mb = int(re.search(r"max_size (\d+)MB", caddy).group(1))
    assert mb >= Settings.model_fields["max_upload_mb"].default


def test_dask_services_use_existing_flags():
    svc = compose()["services"]
    for name in ("dask-scheduler", "dask-worker"):
        cmd = svc[name]["command"]
        helptext = subprocess.run(
            [sys.executable, "-m", "dask", cmd[1], "--help"], capture_output=True, text=True, timeout=120
        ).stdout
        for flag in (a for a in cmd[2:] if a.startswith("--")):
            assert flag in helptext, (name, flag)


def test_nginx_example():
    conf = (DOCKER / "nginx.conf").read_text()
    default_port = cli.build_parser().parse_args(["serve"]).port or Settings.model_fields["port"].default
    assert f"proxy_pass http://127.0.0.1:{default_port};" in conf
    assert "proxy_buffering off" in conf  # Server-Sent Events
    viewer = conf[conf.index("location /viewer") :]
    assert "proxy_set_header Upgrade $http_upgrade" in viewer  # the 3D preview's websocket
    assert "ssl_certificate" in conf and "return 301 https://" in conf
    mb = int(re.search(r"client_max_body_size (\d+)m", conf).group(1))
    assert mb >= Settings.model_fields["max_upload_mb"].default


def _image_env(monkeypatch, tmp_path, token_file: Path | None):
    """The compose file's environment for the waamflow service, with container paths moved into tmp."""
    for k in SETTINGS_ENV:
        monkeypatch.delenv(k, raising=False)
    env = dict(dockerfile()["env"], **compose()["services"]["waamflow"]["environment"])
    env.pop("WAAMFLOW_SCHEDULER")  # no Dask cluster here: runs use local processes
    if token_file is None:
        env.pop("WAAMFLOW_TOKEN_FILE")
    else:
        env["WAAMFLOW_TOKEN_FILE"] = str(token_file)
    for k, v in env.items():
        if k.startswith("WAAMFLOW_"):
            monkeypatch.setenv(k, v.replace("/app/", f"{tmp_path}/app/").replace("/data", f"{tmp_path}/data"))
    monkeypatch.setenv("WAAMFLOW_START_VIEWER", "false")
    return [
        a.replace("/app/", f"{tmp_path}/app/").replace("/data", f"{tmp_path}/data") for a in dockerfile()["cmd"][1:]
    ]


def test_image_command_serves_only_with_the_token(monkeypatch, tmp_path, capsys):
    import uvicorn

    (tmp_path / "app" / "graphs").mkdir(parents=True)
    started = {}
    monkeypatch.setattr(uvicorn, "run", lambda app, host, port, **kw: started.update(app=app, host=host, port=port))

    argv = _image_env(monkeypatch, tmp_path, None)
    assert cli.main(argv) == 2 and not started  # no token: refuses 0.0.0.0
    assert "WAAMFLOW_TOKEN" in capsys.readouterr().err

    tf = tmp_path / "tokens.txt"
    tf.write_text(f"alice:{TOKEN}\n")
    argv = _image_env(monkeypatch, tmp_path, tf)
    assert cli.main(argv) == 0
    assert started["host"] == "0.0.0.0" and started["port"] == 8000
    with TestClient(started["app"]) as c:
        assert c.get("/api/health").json()["auth_required"] is True
        assert c.get("/api/graphs").status_code == 401
        assert c.get("/api/graphs", headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200
    assert (tmp_path / "data" / "waamflow.sqlite").is_file()  # --data /data of the image


def test_env_settings_reach_serve(monkeypatch, tmp_path):
    """`serve` flags override WAAMFLOW_* variables; unset flags leave them in effect."""
    import uvicorn

    started = {}
    monkeypatch.setattr(uvicorn, "run", lambda app, host, port, **kw: started.update(host=host, port=port))
    monkeypatch.setenv("WAAMFLOW_PORT", "8117")
    monkeypatch.setenv("WAAMFLOW_DATA_DIR", str(tmp_path / "envdata"))
    monkeypatch.setenv("WAAMFLOW_START_VIEWER", "false")
    assert cli.main(["serve"]) == 0 and started == {"host": "127.0.0.1", "port": 8117}
    assert cli.main(["serve", "--port", "8118"]) == 0 and started["port"] == 8118
    monkeypatch.setenv("WAAMFLOW_PORT", "eighty")
    assert cli.main(["serve"]) == 2


def test_readme_limits_are_the_defaults():
    """The lab-server tutorial's **Limits** paragraph states each limit's default; they are the settings'."""
    readme = (DOCKER.parent / "docs" / "tutorials" / "lab-server.md").read_text()
    para = readme[readme.index("**Limits**") :]
    para = para[: para.index("\n\n")]
    stated = {name: float(num.replace(" ", "")) for name, num in re.findall(r"`(\w+)`\s+(\d[\d ]*\d|\d)\b", para)}
    assert set(stated) >= {
        "run_timeout_s",
        "max_layers",
        "max_points",
        "max_artifact_mb",
        "max_memory_mb",
        "max_queued_runs",
        "max_upload_mb",
        "max_body_mb",
        "max_triangles",
        "max_dxf_entities",
        "max_uncompressed_mb",
        "preview_timeout_s",
    }, stated
    for name, value in stated.items():
        assert Settings.model_fields[name].default == value, name
