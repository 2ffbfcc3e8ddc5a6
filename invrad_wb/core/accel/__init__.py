"""OpenCL acceleration with numpy twins.

* :mod:`.device`: device policy (``INVRAD_OPENCL=0``, ``PYOPENCL_CTX``, GPU before CPU),
  the program cache and :func:`~.device.check_backend`.
* :mod:`.registry`: each kernel wrapper paired with its numpy twin;
  ``implementation(name, backend)`` is the one place the backend picks a function.
* :mod:`.buffers`: :func:`~.buffers.device_buffer`, :func:`~.buffers.float4` and chunked
  launches, used by every kernel wrapper.
* :mod:`.clenv`: the former module name, re-exporting the above.

Importing this package never imports pyopencl.
"""
