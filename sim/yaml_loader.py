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

__all__ = ["MAX_NODES", "YamlLoader", "load_yaml"]

#: Most values a YAML document may hold once its aliases are expanded [-]: a rig file
#: holds a few hundred, a console paste of 100 records a few thousand.
MAX_NODES = 200_000


class YamlLoader(yaml.SafeLoader):
    """The safe loader with the floats of YAML 1.2 and JSON (``1.4e6`` is a number), and
    a key given twice in one mapping refused, as YAML 1.2 requires (PyYAML kept the last:
    a record pasted with two ``p1`` lines was diagnosed on the second without a word)."""

    def get_single_node(self) -> yaml.Node | None:
        """The document's node, refused when its aliases expand to more than
        :data:`MAX_NODES` nodes: a 340-byte paste of nested aliases ("billion laughs")
        took 9.7 s and 285 MB of a worker once expanded (a security review's pass); an
        anchor shared by a few hoses stays as cheap as written."""
        try:
            node = super().get_single_node()
        except RecursionError:
            # 800 nested brackets: a 500 from the console (a verification pass)
            raise yaml.composer.ComposerError(
                None, None, "the document nests deeper than it can be read", None) from None
        if node is not None:
            size: dict[int, int] = {}

            def expanded(n: yaml.Node) -> int:
                if id(n) in size:
                    return size[id(n)]
                size[id(n)] = 1      # a recursive alias counts once
                children = ([c for pair in n.value for c in pair]
                            if isinstance(n, yaml.MappingNode) else
                            n.value if isinstance(n, yaml.SequenceNode) else [])
                total = 1 + sum(expanded(c) for c in children)
                size[id(n)] = total
                if total > MAX_NODES:
                    raise yaml.composer.ComposerError(
                        None, None, f"the document expands to more than {MAX_NODES:,} "
                        "values through its aliases (&anchor / *alias)", n.start_mark)
                return total

            try:
                expanded(node)
            except RecursionError:
                raise yaml.composer.ComposerError(
                    None, None, "the document nests deeper than it can be read",
                    None) from None
        return node

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, yaml.Mark] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.setdefault(key, key_node.start_mark)
            except TypeError:  # an unhashable key: the base class says so
                break
            if first is not key_node.start_mark:
                raise yaml.constructor.ConstructorError(
                    "while reading a mapping", node.start_mark,
                    f"the key {key!r} is given twice (line {first.line + 1} and line "
                    f"{key_node.start_mark.line + 1})", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


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
