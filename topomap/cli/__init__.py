"""The tools around the library: the ``topomap`` command line (:mod:`topomap.cli.main`, one
module per command in :mod:`topomap.cli.commands`), the demo, benchmarks, evaluations and
pictures. Nothing in the library packages imports from here.

The tools run BLAS in one thread unless ``OPENBLAS_NUM_THREADS`` says otherwise (set here,
before NumPy, SciPy and OpenCV load their OpenBLAS): each of the three starts a pool of
threads that spin while they wait, which costs ``topomap segment`` 0.1 s of its start-up on
two cores, and none of the pipeline's BLAS work is large enough to gain from threads (the
spectral partition limits them to one anyway, :mod:`segmentation.spectral`).

NumPy is told not to ask the kernel for huge pages for its large arrays
(``NUMPY_MADVISE_HUGEPAGE``, unless set): where the kernel hands them out only on request
(``transparent_hugepage`` ``madvise``, as on the project's machines), it then finds and clears
2 MB pages on each new large array, in system time: ``topomap segment`` on office_g, the
largest ipa plan, 2.5 s of it against 0.3 s without (3.4 s in all instead of 6; the same
results).
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
