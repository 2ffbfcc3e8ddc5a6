"""The former single OpenCL module, kept so that ``invrad_wb.core.accel.clenv`` still imports.

Device policy lives in :mod:`invrad_wb.core.accel.device`, buffers and launches in
:mod:`invrad_wb.core.accel.buffers`, the OpenCL/numpy pairs in
:mod:`invrad_wb.core.accel.registry`. New code imports from those; patch them, not this
module (names here are copies of theirs).
"""
from invrad_wb.core.accel.buffers import device_buffer, float4, launch_chunked, round_up
from invrad_wb.core.accel.device import (BACKENDS, ENV_SWITCH, CLEnv, check_backend,
                                         get_env, opencl_available, opencl_disabled,
                                         opencl_unavailable_reason)

__all__ = ["BACKENDS", "ENV_SWITCH", "CLEnv", "check_backend", "device_buffer", "float4",
           "get_env", "launch_chunked", "opencl_available", "opencl_disabled",
           "opencl_unavailable_reason", "round_up"]
