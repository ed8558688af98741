"""The command line's subcommands, one module each: its argument parser and ``main(argv)``.

Each module is a thin layer over the library (argument parsing, validation before any work,
printing); :mod:`planar3p_agents.cli` dispatches ``planar3p <command>`` to it, and the files in
the repository's ``scripts/`` folder are one-line calls of the same command.
"""
