import sys

from ..cli import run_main
from . import main

run_main(lambda: main(sys.argv[1:]))
