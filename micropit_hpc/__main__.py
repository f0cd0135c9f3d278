import sys

from micropit_hpc.cli import main

sys.exit(main())
