"""``python -m studies`` is the ``studies`` command."""

from .cli import console_main  # sets the BLAS thread count before numpy loads

if __name__ == "__main__":      # not when a worker process (figures) imports this as its main module
    console_main()
