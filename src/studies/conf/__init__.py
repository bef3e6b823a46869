"""The packaged configuration: Hydra YAML files, each bound to its schema.

Importing this package registers the schemas of :mod:`studies.config` in
Hydra's ConfigStore, so that composing from ``studies.conf`` (the command
line, :func:`studies.config.compose_settings`, tests) always type-checks.
"""

from .. import config  # noqa: F401  (registers the schemas)
