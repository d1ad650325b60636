"""Response bodies shared by the HTTP API's routes, and the answers they document.

The commands' request bodies (strict angles, unknown fields refused: a 422 naming the
field) are urc.dispatch.bodies', shared with MQTT; the web-only ones build on its Strict.
"""

from __future__ import annotations

from pydantic import BaseModel, Field


class Ok(BaseModel):
    ok: bool = True


class Problem(BaseModel):
    """401/403/404/413 answers (FastAPI's ``HTTPException`` shape)."""

    detail: str


class Refusal(BaseModel):
    """409: the command was understood and refused (limits, keep-out, a fault, busy...)."""

    ok: bool = False
    error: str
    reason: str


class FieldError(BaseModel):
    loc: list[str | int]
    msg: str
    type: str


class Invalid(BaseModel):
    """422: the request did not validate; each entry names the field."""

    detail: list[FieldError]


#: documented on every control route (the answers a refused command can get)
CONTROL_RESPONSES: dict[int | str, dict] = {
    401: {"model": Problem, "description": "control needs the API token"},
    403: {"model": Problem, "description": "control from another site or through a foreign host name"},
    409: {"model": Refusal, "description": "refused by the rotator (limits, keep-out, fault, busy)"},
    413: {"model": Problem, "description": "request body too large"},
    422: {"model": Invalid, "description": "invalid request (each error names its field)"},
}


# ------------------------------------------------------------ documented answers of the views
# (described for the OpenAPI page, not re-validated on every call: /api/status is polled)
class AxisState(BaseModel):
    pos_deg: float = Field(description="mechanical position (add offsets for the pointing frame)")
    rate_deg_per_s: float
    target_deg: float | None
    mode: str
    duty: float
    brake_released: bool
    uncertainty_deg: float = Field(description="0 when the position is known")
    limit_min: bool
    limit_max: bool
    current_a: float
    sensor_ok: bool = Field(description="the sensor (or bridged controller) answered this tick; "
                                        "false: pos_deg is the last reading, unconfirmed")
    sensor_error: str = Field(description="why the sensor does not answer (empty while it does)")


class FaultInfo(BaseModel):
    kind: str
    reason: str


class StatusDoc(BaseModel):
    """The rotator's snapshot (``urc status``); more keys may be added."""

    t_s: float
    profile: str
    az_deg: float = Field(description="pointing azimuth")
    el_deg: float | None = Field(description="pointing elevation (None: azimuth-only rotator)")
    az: AxisState
    el: AxisState | None = Field(description="None on an azimuth-only rotator (axes = ['az'])")
    axes: list[str] = Field(description="the rotator's axes: ['az', 'el'], or ['az'] (single-axis)")
    target_az_deg: float | None
    target_el_deg: float | None
    flipped: bool
    wrap_turns: int
    moving: bool
    parked: bool
    position_known: bool
    faults: list[FaultInfo]
    events: list[str]
    tick_late_p99_ms: float
    limits: dict[str, tuple[float, float]]
    offsets: dict[str, float]
    state_error: str
    loop: dict = Field(description="control-loop timing: late_p99_ms (outputs written after the deadline, "
                                   "whole tick), tick_p99_ms, stalls, recent_stalls, held (motors held off "
                                   "after a stall, resuming when on time), last_stall_ms")
    local_control: list[str] = Field(description="front-panel controls held now: motion from here is refused")
    procedures: dict[str, str] = Field(description="per axis, a procedure running now (\"reference search\": "
                                                   "homing); its position is no number to give a client")
    last_stop: dict | None = Field(description="the last stop urc made by itself: kind (health | fault), reason, "
                                               "command (what it cut), t_s, resumes (goes on once healthy)")
    program: dict | None = Field(description="the pass program the control process flies: id, name, state "
                                             "(waiting | prepositioning | tracking), aos_s, los_s")
    program_end: dict | None = Field(description="how the last pass program ended: id, name, why (done | stopped | "
                                                 "replaced by ...), t_s")
    simulator_truth: dict | None = Field(description="the simulator's true state (None on hardware)")
    tracking: dict | None = Field(description="the tracker's status (target, az/el, plan, ground track)")
    cycle: dict = Field(description="the Berkeley state machine's name for what urc does now: state "
                                    "(setup | process_tle | predict | track | report), document (the "
                                    "document's name: setup, PROCESS_TLE, PREDICT, TRACK_MOTOR, "
                                    "UPDATE_SERVER) and why (urc.tracking.cycle)")
    loop_lag: dict | None = Field(description="how late the I/O process's event loop ran a 0.1 s timer "
                                              "(urc.servers.loop_lag): p50_ms, p99_ms, max_ms over window_s, "
                                              "max_since_start_ms, samples; null when the probe is not running")


class ZoneInfo(BaseModel):
    name: str
    az_min_deg: float
    az_max_deg: float
    el_min_deg: float
    el_max_deg: float


class InfoDoc(BaseModel):
    """What the dashboard needs to know about this urc; more keys may be added."""

    version: str
    profile: str
    description: str
    backend: str
    simulator: bool
    control_requires_token: bool
    token_configured: bool
    can_flip: bool
    caps: dict[str, dict]
    axes: list[str] = Field(description="['az', 'el'], or ['az'] for a single-axis rotator")
    limits: dict[str, tuple[float, float]]
    offsets: dict[str, float]
    keepout: list[ZoneInfo] = Field(description="the zones the rotator enforces now")
    restart_pending: list[str] = Field(description="saved sections that take effect at the next start")
    station: dict | None
    tracking_min_el_deg: float
    frame_hz: float
    jog_lease_s: float
    tracking_available: bool
    profiles: dict[str, str]
    protocols: list[str]
    control: dict[str, int | str] = Field(description="the control loop's process (pid) and the scheduling "
                                                      "priority it was given")


class HistoryDoc(BaseModel):
    """Samples as parallel arrays (one entry per sample)."""

    which: str
    label: str
    count: int
    t_wall_s: list[float]
    az_deg: list[float | None]
    el_deg: list[float | None]
    target_az_deg: list[float | None]
    target_el_deg: list[float | None]
    error_deg: list[float | None]
    az_mech_deg: list[float | None]
    az_target_mech_deg: list[float | None]


def documented(model: type[BaseModel]) -> dict:
    """Route options that describe the answer with ``model`` without validating it."""
    return {"response_model": None, "responses": {200: {"model": model}}}
