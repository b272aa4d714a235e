"""A public model rendered to JSON bytes in the route's own thread.

FastAPI validates a sync route's return value in a worker thread, but renders the JSON of
the answer (``jsonable_encoder`` and ``json.dumps``) on the event loop: a trends answer of
786 KB held the loop ~170 ms, and ``/health`` p99 rose to 152-253 ms while two clients read
trends and history pages (an operator pass).  A heavy read returns :func:`rendered`
instead: pydantic's compiled serialiser, in the thread that ran the route; the event loop
only sends bytes.  The route keeps its ``response_model`` for the OpenAPI schema.
"""

from __future__ import annotations

from fastapi import Response
from pydantic import BaseModel

__all__ = ["rendered"]


def rendered(model: BaseModel, *, status_code: int = 200) -> Response:
    """``model`` as an ``application/json`` response, rendered now."""
    return Response(model.model_dump_json().encode(), status_code=status_code,
                    media_type="application/json")
