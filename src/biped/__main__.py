import sys

from biped.cli import main

sys.exit(main())
