import sys

from ..cli import run_main
from . import main
from .temporal import before_sweep


def _main(argv) -> None:
    before_sweep(argv)            # the sweep's preset's temporal series, read by its report
    main(argv)


run_main(lambda: _main(sys.argv[1:]))
