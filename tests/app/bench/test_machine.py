"""run.json's machine: the GPU's clocks where nvidia-smi reads them."""
import os

from app.bench import machine


def _fake_smi(tmp_path, body):
    exe = tmp_path / "nvidia-smi"
    exe.write_text("#!/bin/sh\n" + body + "\n")
    exe.chmod(0o755)
    return str(tmp_path) + os.pathsep + os.environ["PATH"]


def test_clocks_read_from_nvidia_smi(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", _fake_smi(tmp_path, 'echo "345 MHz, 1980 MHz, P8"'))
    assert machine.gpu_clocks() == "SM 345 MHz of 1980 MHz, P8"
    assert machine.machine_info()["gpu_clocks"] == "SM 345 MHz of 1980 MHz, P8"


def test_no_clocks_without_nvidia_smi_or_when_it_fails(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert machine.gpu_clocks() is None and "gpu_clocks" not in machine.machine_info()
    monkeypatch.setenv("PATH", _fake_smi(tmp_path, "exit 9"))
    assert machine.gpu_clocks() is None
    monkeypatch.setenv("PATH", _fake_smi(tmp_path, "echo garbled"))
    assert machine.gpu_clocks() is None
