"""What the scripts of ``scripts/`` share, not installed: the studies behind the results pages,
the environment and kinematics throughput measures (:mod:`tooling.throughput`,
:mod:`tooling.kinematics_throughput`) and :mod:`tooling.script`, which runs a script's command.

The scripts import it as ``tooling`` (``scripts/`` is the first entry of ``sys.path`` when one
runs); the tests put ``scripts/`` on the path too (``pythonpath`` in ``pyproject.toml``).
"""
