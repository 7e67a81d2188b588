"""Performance benchmarks of the co-simulation master against its peers.

``python -m benchmarks`` times, in ONE run and side by side, the same co-simulation in every tool:

* the cases: a ring of six trivial pythonfmu FMUs (:func:`benchmarks.cases.ring`: Gain FMUs, each one's
  ``integral`` feeding the next one's ``u``, so no algebraic loop) and the exported SSP of each press drive
  (feeder_gto52, bed_drive, spine_knife, proof_press) and of the two-inertia benchmark, all at one fixed step
  per case;
* the tools (:mod:`benchmarks.runners`): the harness with each master (its default path: the toolkit's
  pythonfmu FMUs called in-process, :mod:`harness.fmi.inprocess`), the harness's ``jacobi-sampled`` on the plain
  FMI path (``jacobi-sampled-fmi``: every FMU through its C library), libcosim (libcosimpy), Ecos (ecospy,
  the SSP's parameter set ``default`` passed to ``init``), CoFmuPy (in a virtual environment of its own,
  :mod:`benchmarks.cofmupy`: it pins an older pythonfmu and fmpy), the bare fmpy loop
  (``FMU2Slave.setReal/doStep/getReal``, the "fmpy floor") and a ctypes floor (prepared arrays, direct FMI
  calls, no checks: the least a Python master on the FMI path can cost);
* pinned (``taskset -c 0``) and unpinned; every configuration runs in its own subprocess
  (``python -m benchmarks.worker``);
* the real-time factor of bed_drive: its default scene (the coarsest model that answers the scene's question
  within tolerance, :func:`harness.studies.scenes.choose`) and, for comparison, its default experiment (the
  declared model);
* the real-time factors of the declared models of bed_drive and feeder_gto52 against their goals (:mod:`benchmarks.bench`), each
  beside its two floors (:mod:`benchmarks.floors`: the same run with the FMUs' physics, or all their calls,
  made free after initialisation: the most a faster model, or a faster FMU layer as well, could give with
  this master), and a warm sweep worker's per-point overhead.

It prints the cost per FMU-step [us] and the ratios harness/peer, writes ``benchmark.csv`` and the bar chart
``docs/images/benchmark.png`` (+ .svg), checks that every tool computed the same thing (final values of the
outputs without direct feed-through, against the harness with master ``jacobi-sampled``, which is the
algorithm of libcosim, Ecos and CoFmuPy) and checks the targets (``SCENE_GOAL``, ``DECLARED_GOALS``, ``SWEEP_GOAL`` in :mod:`benchmarks.bench`).  ``--quick`` runs tiny sizes
(a smoke test, timings meaningless).  Timings on a shared machine are noisy: run the final benchmark on a
quiet one.

Every tool is timed over the same scope here: its initialisation and stepping.  The time a user waits for
at each drive's declared accuracy, each tool at its own step, in two scopes side by side (stepping alone;
the whole process from start to exit, writing the same columns) and a sweep: ``python -m benchmarks.scopes``.
Where the time goes, in CPU seconds: ``python -m benchmarks.step_parts`` (a co-simulation step in the harness and
in Ecos, part by part, with the floor of their ratio) and ``python -m benchmarks.sweep_parts`` (a sweep in the
harness's warm worker and in OMSimulator, part by part).
"""
