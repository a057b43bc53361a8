"""The CAPTAIN on the blackboard (seed §2.3.1): missions sequenced one step at a time; `python -m codger.captain`."""

from codger.captain.service import Captain, CaptainOptions

__all__ = ["Captain", "CaptainOptions"]
