"""``python -m mlspaces.data_generation.main [MODULE:]CONFIG`` (MolmoSpaces' entry point)."""

from ..datagen.run import main

if __name__ == "__main__":
    main()
