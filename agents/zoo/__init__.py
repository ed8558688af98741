"""The zoo of shipped policies: their one layout (:mod:`~planar3p_agents.zoo.layout`, an rl-zoo3
log folder per model in ``pretrained/``), shipping a run (:mod:`~planar3p_agents.zoo.shipping`),
the checksum manifest and its check (:mod:`~planar3p_agents.zoo.manifest`), and the scan for
traces of the training machine (:mod:`~planar3p_agents.zoo.portable`)."""
