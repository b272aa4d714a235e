"""YAML read with the numbers of YAML 1.2 and JSON: ``1.4e6``, ``34e-6`` are floats.

PyYAML implements YAML 1.1, whose float pattern needs a dot and a signed exponent: it
reads ``34e-6`` and ``14.50e5`` as text, and a rig file, a record or a throttle table
written so was refused with "must be a number" without saying why.  Every YAML the
project reads (rig files, CLI documents, the console's pasted records) goes through
:class:`YamlLoader`.
"""

from __future__ import annotations

import re
from typing import Any

import yaml

__all__ = ["YamlLoader", "load_yaml"]


class YamlLoader(yaml.SafeLoader):
    """The safe loader with the floats of YAML 1.2 and JSON (``1.4e6`` is a number)."""


YamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
               |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
               |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
               |[-+]?\.(?:inf|Inf|INF)
               |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."))


def load_yaml(text: str) -> Any:
    """The document of ``text`` read by :class:`YamlLoader`."""
    return yaml.load(text, YamlLoader)
