"""A run's surroundings, for the layers above the core: progress on long work (progress),
time and memory budgets (budget), and advice to the user (advice); a silenced
stdout for chatty C libraries is jaxflex.stdout (light, for readers in a child process);
JAX's persistent compilation cache (compile_cache: enable_compile_cache, its environment
variable COMPILE_CACHE_ENV and entry suffix COMPILE_CACHE_SUFFIX) and the stores of other
reusable work beside it (cache_store, cache_fetch: entries checked on every read, one run
making an entry while the others wait for it).
Public: these names are kept stable; the modules they come
from are private.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxflex._budget import (
    Need,
    check_time,
    current_budget,
    format_bytes,
    require,
)
from jaxflex._compile_cache import ENV_VAR as COMPILE_CACHE_ENV
from jaxflex._compile_cache import SUFFIX as COMPILE_CACHE_SUFFIX
from jaxflex._compile_cache import FileStore as CacheStore
from jaxflex._compile_cache import enable as enable_compile_cache
from jaxflex._compile_cache import fetch as cache_fetch
from jaxflex._compile_cache import pack_text as cache_pack_text
from jaxflex._compile_cache import store as cache_store
from jaxflex._compile_cache import unpack_text as cache_unpack_text
from jaxflex._progress import (
    note,
    progress_bar,
    step,
)
from jaxflex.lazy import lazy_names

if TYPE_CHECKING:  # it reads models (JAX): imported on first use (jaxflex.lazy)
    from jaxflex._advice import Advice, issue, model_resolution, threshold_advice

__getattr__, __dir__ = lazy_names(__name__)

__all__ = [
    "COMPILE_CACHE_ENV",
    "COMPILE_CACHE_SUFFIX",
    "Advice",
    "CacheStore",
    "Need",
    "cache_fetch",
    "cache_pack_text",
    "cache_store",
    "cache_unpack_text",
    "check_time",
    "current_budget",
    "enable_compile_cache",
    "format_bytes",
    "issue",
    "model_resolution",
    "note",
    "progress_bar",
    "require",
    "step",
    "threshold_advice",
]
