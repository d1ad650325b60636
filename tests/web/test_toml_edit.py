"""In-place TOML edits (the settings save): only the changed keys, checked by reading back."""

import tomllib

import pytest

from urc.web import toml_edit


def test_a_new_table_under_dotted_keys_stays_under_them():
    """tomlkit alone put the new table at the top level ([gpio.az.pins]: another key)."""
    text = '[hardware]\nbackend = "gpio"   # the Pi\ngpio.emulate = false\ngpio.az.motor = "relay"\n'
    old = {"hardware": {"backend": "gpio", "gpio": {"emulate": False, "az": {"motor": "relay"}}}}
    new = {"hardware": {"backend": "gpio", "gpio": {"emulate": False, "az": {"motor": "vnh5019", "pins": {"a": 1}}}}}
    out = toml_edit.edit(text, old, new)
    assert tomllib.loads(out) == new
    assert out.startswith('[hardware]\nbackend = "gpio"   # the Pi\ngpio.emulate = false\n')


def test_lists_of_tables_removed_keys_and_untouched_overrides():
    text = "# mine\n[api]\nport = 8080 # web\n\n[[serve]]\nprotocol = \"rotctld\"\ntcp = \"127.0.0.1:4533\"\n"
    old = {"api": {"port": 8080, "host": "127.0.0.1"}, "serve": [{"protocol": "rotctld", "tcp": "127.0.0.1:4533"}],
           "hardware": {"gpio": {"emulate": True}}, "park": {"az_deg": 10.0}}
    new = {"api": {"port": 8080, "host": "127.0.0.1"}, "hardware": {"gpio": {"emulate": True}},
           "serve": [{"protocol": "gs232b", "pty": "/tmp/x", "options": {"variant": "b"}}]}
    out = toml_edit.edit(text, old, new)
    assert out.startswith("# mine\n[api]\nport = 8080 # web\n")
    assert tomllib.loads(out) == {"api": {"port": 8080},
                                  "serve": [{"protocol": "gs232b", "pty": "/tmp/x", "options": {"variant": "b"}}]}


def test_a_broken_file_is_not_touched():
    with pytest.raises(ValueError):
        toml_edit.edit("[api\nport = 1\n", {"api": {"port": 1}}, {"api": {"port": 2}})


def test_a_whole_number_stays_an_integer_where_the_file_has_one():
    """Issue 36 item 9: the schema reads ``alt_m = 70`` as 70.0, and a save wrote 71.0.
    A float the file holds stays a float; so does a key the file lacks (the schema's type)."""
    text = "[station]\nalt_m = 70   # the mast\n\n[offsets]\naz_deg = 1.5\n"
    old = {"station": {"alt_m": 70.0}, "offsets": {"az_deg": 1.5}}
    new = {"station": {"alt_m": 71.0}, "offsets": {"az_deg": 2.0, "el_deg": 3.0}}
    out = toml_edit.edit(text, old, new)
    assert out == "[station]\nalt_m = 71   # the mast\n\n[offsets]\naz_deg = 2.0\nel_deg = 3.0\n"
