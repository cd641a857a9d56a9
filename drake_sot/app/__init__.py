"""Front-ends, the top layer: the ``drake-sot`` command line (:mod:`~drake_sot.app.cli`), serving a
scenario to remote clients (:mod:`~drake_sot.app.serving`) and its live Meshcat status view
(:mod:`~drake_sot.app.status`). They import the scenarios, the systems and the transport; nothing
imports them."""
