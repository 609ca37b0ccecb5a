"""Shared fixtures: one ``device`` per available Warp device."""

import logging

import pytest
import warp as wp

wp.config.log_level = logging.WARNING  # no start-up banner
wp.init()

DEVICES = [str(d) for d in wp.get_devices()]


@pytest.fixture(params=DEVICES)
def device(request):
    """Every available Warp device: the CPU always, CUDA devices where present."""
    return request.param
