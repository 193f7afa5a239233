"""The performance tooling of ``pfbench bench``: how fast the kernels run beside numpy, a C
reference and the peers, what ``pfbench run`` adds to them, and how far each is from the sum of
its irreducible passes (docs/internals/benchmarks.md).

Nothing in the library imports this package (tests/test_bench_layout.py holds it to that); the
command line imports ``suite.run_bench`` inside its ``bench`` command. Its modules:

- common: the UNGM workload, its data and its kernel run once, and the timer;
- ungm_pf: part ``ungm``, the bootstrap PF beside numpy and the C reference;
- filter_costs: part ``costs``, every scalar filter's cost per step;
- fastslam_course, afsa_world, mcl_field: parts ``fastslam``, ``afsa``, ``mcl``;
- peers: ``--peers``, the same filter written with particles and filterpy;
- run_path: parts ``run``, ``run-ungm``, ``run-mcl``, ``run-fastslam``;
- limits: part ``limit`` (``--limit``), each kernel's passes timed alone;
- records: ``--compare``, an earlier run's records beside this run's;
- suite: ``run_bench``, the parts in order and the JSON.
"""
