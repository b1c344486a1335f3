"""Where a run's lanes go: lane groups (one program per core), device sharding, and several
processes or hosts (``jax.distributed``, ``local_processes=N``)."""
