"""The physics backends under the tasks: MuJoCo C inside the jitted program (native.py, the XLA FFI
call native_ffi.py/.cc) and the MJX patches that make MJX match MuJoCo C (mjx_compat.py,
mjx_solver.py, small_linalg.py)."""
