"""``python -m atlas_rap`` is the ``atlas`` command."""

from atlas_rap.cli.main import main

if __name__ == "__main__":
    main()
