"""Shared fixtures: one ``device`` per available Warp device."""

import logging

import pytest
import warp as wp

wp.config.log_level = logging.WARNING  # no start-up banner
wp.init()

DEVICES = [str(d) for d in wp.get_devices()]


def pytest_configure(config):
    """Every kernel module compiled for the CPU (or loaded from Warp's cache) before the first test,
    as many at a time as there are CPUs: with an empty cache, the tests would otherwise compile
    them one after another as they first use each, and with ``-n`` every worker would compile each
    for itself (the workers start after this, in the process that runs them)."""
    if hasattr(config, "workerinput"):  # a pytest-xdist worker: its controller compiled them
        return
    from wdendrite.warmup import load_kernels

    load_kernels("cpu", progress=False)


@pytest.fixture(params=DEVICES)
def device(request):
    """Every available Warp device: the CPU always, CUDA devices where present."""
    return request.param


@pytest.fixture
def launches(monkeypatch):
    """The kernels launched while a test runs (by name): Warp's launch and its recorded launches, recording calls."""
    seen = []
    real, real_recorded = wp.launch, wp.Launch.launch

    def recording(kernel, *args, **kwargs):
        seen.append(kernel.key)
        return real(kernel, *args, **kwargs)

    def recorded(self, *args, **kwargs):
        seen.append(self.kernel.key)
        return real_recorded(self, *args, **kwargs)

    monkeypatch.setattr(wp, "launch", recording)
    monkeypatch.setattr(wp.Launch, "launch", recorded)
    return seen


@pytest.fixture
def python_sigint():
    """Python's own Ctrl-C handler (``KeyboardInterrupt``) installed for the test, which sends a real
    SIGINT to its own process; pytest-xdist's workers ignore SIGINT otherwise. Skips where the test
    does not run in the main thread, the only one a signal handler runs in."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("a real SIGINT is handled only in the main thread, and this test runs in another")
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
