"""``python -m onepiece_dist.cli``: the ``onepiece`` command (Ray's job entrypoints call it so)."""

from onepiece_dist.cli.main import main

main()
