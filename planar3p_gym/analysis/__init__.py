"""Analyses of the machine: the paper's workspace-versus-stroke study, its report and figures."""
