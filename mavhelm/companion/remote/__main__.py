"""``python -m mavhelm.companion.remote``: the console without the ``mavhelm`` command."""

import sys

from mavhelm.companion.remote.terminal import main

sys.exit(main())
