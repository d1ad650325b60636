"""Settings page back end: validate with ``Config.from_dict``, save as TOML, apply.

The page edits the whole configuration document and posts it back, so settings it has
no field for survive a save. The save edits the person's file in place (:mod:`.toml_edit`):
only the keys that changed, comments and order kept; a value that only the command line
set (``--emulate``, ``--port``) is not a change and never reaches the file. The API
token is never sent to the page: a posted document without one keeps the present token. Sections that need a restart (profile, hardware,
API address, state, protocol ports) are reported as such; the others are applied live
when the rotator can take new settings (``Rotator.reconfigure``), else at the restart.
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
import secrets
import stat
from pathlib import Path
from typing import Any

from ..config import DEFAULT_SERVE, Config
from ..config.secrets_mode import holds_secret
from ..config.user_copy import is_example, user_copy
from ..errors import ConfigError
from . import toml_edit

SOURCE = "settings"
#: top-level sections whose change only takes effect when ``urc run`` restarts
RESTART_SECTIONS = ("rotator", "hardware", "api", "state", "serve", "station", "tracking", "mqtt")
CONFIG_NAME = "urc.toml"


def config_errors(exc: ConfigError) -> list[dict[str, str]]:
    """One entry per problem: the dotted key (for the field) and the message."""
    errs = getattr(exc, "errors", None) or [exc]
    out = []
    for e in errs:
        text = str(e).split("\n")[0]
        prefix = f"{SOURCE}: "
        if text.startswith(prefix):
            text = text[len(prefix):]
        key = e.key or ""
        if key and text.startswith(key + ": "):
            text = text[len(key) + 2:]
        out.append({"key": key, "message": text})
    return out


class SettingsStore:
    def __init__(self, cfg: Config, config_path: str | os.PathLike | None,
                 state_dir: str | os.PathLike | None):
        self.cfg = cfg
        #: the configuration urc run started with (what a restart-only section still is)
        self.running = cfg
        self.config_path = Path(config_path) if config_path else None
        self.state_dir = Path(state_dir) if state_dir else None
        #: what the last save has to say besides where it went (an example copied)
        self.note = ""
        # (the revision hashes the whole configuration, token included: salted per
        # process so that the ETag tells nothing about the token)
        self._salt = secrets.token_bytes(16)

    @property
    def revision(self) -> str:
        """The settings document's revision, an RFC 9110 strong entity tag (quotes
        included): a save whose If-Match names another is refused (412), so a page
        loaded before someone else's save cannot undo it."""
        text = json.dumps(self.cfg.to_dict(), sort_keys=True, default=str).encode()
        return '"' + hashlib.sha256(self._salt + text).hexdigest()[:20] + '"'

    def if_match(self, header: str | None) -> bool | None:
        """Whether a save's ``If-Match`` names the current revision (RFC 9110 13.1.1:
        a list of strong tags, or ``*``); None when there is no If-Match."""
        if header is None:
            return None
        tags = [t.strip() for t in header.split(",")]
        return "*" in tags or self.revision in tags

    @property
    def target_path(self) -> Path | None:
        if self.config_path is not None:
            return self.config_path
        return self.state_dir / CONFIG_NAME if self.state_dir is not None else None

    def document(self) -> dict[str, Any]:
        """What the page edits: the configuration without the token."""
        data = self.cfg.to_dict()
        data.get("api", {}).pop("token", None)
        data.get("api", {}).pop("read_token", None)
        data.get("mqtt", {}).pop("password", None)  # (reading is open: the broker's password is not)
        target = self.target_path
        return {
            "config": data,
            "token_set": bool(self.cfg.api.token),
            "read_token_set": bool(self.cfg.api.read_token),
            "default_serve": [e.model_dump(exclude_none=True) for e in DEFAULT_SERVE],
            "config_path": str(self.config_path) if self.config_path else None,
            "save_path": str(target) if target else None,
            "restart_sections": list(RESTART_SECTIONS),
            "restart_pending": self.restart_pending(),
            "revision": self.revision,
        }

    def _merge_token(self, data: dict[str, Any]) -> dict[str, Any]:
        data = copy.deepcopy(data)
        api = data.setdefault("api", {})
        if isinstance(api, dict) and not api.get("token") and self.cfg.api.token:
            api["token"] = self.cfg.api.token
        if isinstance(api, dict) and not api.get("read_token") and self.cfg.api.read_token:
            api["read_token"] = self.cfg.api.read_token
        mqtt = data.get("mqtt")
        if isinstance(mqtt, dict) and "password" not in mqtt and self.cfg.mqtt is not None and self.cfg.mqtt.password:
            mqtt["password"] = self.cfg.mqtt.password
        return data

    def validate(self, data: Any) -> tuple[Config | None, list[dict[str, str]]]:
        if not isinstance(data, dict):
            return None, [{"key": "", "message": "expected a table of settings"}]
        data = self._merge_token(data)
        try:
            return Config.from_dict(data, source=SOURCE), []
        except ConfigError as exc:
            errors = config_errors(exc)
        for problem in self._section_errors(data):
            if problem not in errors:
                errors.append(problem)
        return None, errors

    def _section_errors(self, data: dict[str, Any]) -> list[dict[str, str]]:
        """The configuration's rules run in stages (types first, then each section against
        the profile), and a document that fails one stage is not checked further: one
        wrong field hid the others. So each section is also checked alone, on top of the
        present settings (and the document's profile), to report every problem at once."""
        base = self._merge_token(self.cfg.to_dict())
        if isinstance(data.get("rotator"), dict):
            try:
                Config.from_dict({**base, "rotator": data["rotator"]}, source=SOURCE)
                base["rotator"] = data["rotator"]
            except ConfigError:
                pass  # the profile itself is wrong: the others are checked against the present one
        out: list[dict[str, str]] = []
        for key, value in data.items():
            if key not in base or key == "rotator":
                continue  # unknown sections and the profile are reported by the whole check
            try:
                Config.from_dict({**base, key: value}, source=SOURCE)
            except ConfigError as exc:
                out += config_errors(exc)
        return out

    def restart_pending(self) -> list[str]:
        """Sections saved but not in effect until ``urc run`` restarts."""
        return [k for k in self.changed_sections(self.running) if k in RESTART_SECTIONS]

    def changed_sections(self, new: Config, against: Config | None = None) -> list[str]:
        old_d, new_d = (against or self.cfg).to_dict(), new.to_dict()
        keys = sorted(set(old_d) | set(new_d))
        return [k for k in keys if old_d.get(k) != new_d.get(k)]

    def save(self, new: Config) -> Path:
        """Write the keys that changed since the last save (or the start) into the file,
        in place, and replace it atomically: a crash leaves the old file or the new one,
        never none. A file that holds a secret (a token, the MQTT password) is made
        0600; another keeps its permissions; a new file is created 0600 and holds only
        what was changed."""
        target = self.target_path
        if target is None:
            raise OSError("no configuration file and no state directory to save to")
        self.note = ""
        example = None
        if is_example(target):  # a template shipped with urc: never written, copied
            example, target = target, user_copy(target)
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            old_mode = stat.S_IMODE(target.stat().st_mode)
            old_text = target.read_text(encoding="utf-8")
        except FileNotFoundError:
            old_mode = None  # (a new file: 0600)
            old_text = example.read_text(encoding="utf-8") if example is not None else ""
        try:
            text = toml_edit.edit(old_text, self.cfg.to_dict(), new.to_dict())
        except (toml_edit.EditError, ValueError) as exc:  # (tomllib: a file broken by hand meanwhile)
            raise OSError(f"{target}: {exc}; the file is left as it was") from exc
        # a file that holds a token is the owner's alone (0600), whatever it was before
        mode = 0o600 if old_mode is None or holds_secret(new) else old_mode
        _write_atomic(target, text.encode("utf-8"), mode)
        self.cfg = new
        if example is not None:
            self.config_path = target
            self.note = (f"{example} is an example (a template, left as it is): saved to your copy {target}, "
                         f"used from now on (`urc run --config {example}` takes it too)")
        return target


def _write_atomic(path: Path, data: bytes, mode: int) -> None:
    """Temp file with ``mode`` from the start (the token is never readable by others),
    fsync, rename over ``path``, fsync the directory."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), mode)  # the umask may have narrowed O_CREAT's mode
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    dfd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)
