"""SSP (System Structure and Parameterization) in and out: :mod:`cosim.ssp.read` turns an SSP archive into the
tables of a run config (``cosim run system.ssp``, or ``[system] ssp = "system.ssp"`` in a config);
:mod:`cosim.ssp.write` writes a run config's plants, connections and parameter values as an SSP
(``cosim export-ssp``). See docs/guide/ssp.md."""
