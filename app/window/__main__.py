"""python -m app.window"""
import sys

from .. import cli
from .launch import main

cli.run_main(lambda: main(sys.argv[1:]))
