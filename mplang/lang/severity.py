"""How bad a finding is. Its own module because the rule registry (`rules`) and the
diagnostics that carry a rule's code (`diagnostics`) both need it, and `diagnostics` reads
the registry."""

from __future__ import annotations

from enum import StrEnum


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"
