"""The firmware's C header, generated from the one protocol dictionary (:mod:`iwp.device.protocol`).

``python tools/gen_protocol_header.py`` writes :func:`c_header` to
``src/iwp/device/csrc/iwp_protocol.h`` (the portable core, also
``firmware/core/``); a test checks that the shipped header is current.
"""

from __future__ import annotations

from pathlib import Path

from .protocol import (
    ACK_CODES,
    CAPS,
    DICTIONARY_HASH,
    FAULTS,
    FIXTURE_ACTIONS,
    FLAGS,
    MAX_PAYLOAD,
    MESSAGES,
    MODES,
    PARAMS,
    PROTOCOL_VERSION,
    STATES,
)

__all__ = ["c_header", "HEADER_PATH"]

#: Where the generated header lives (next to the portable core).
HEADER_PATH = Path(__file__).with_name("csrc") / "iwp_protocol.h"

_C_TYPES = {"B": "uint8_t", "H": "uint16_t", "I": "uint32_t", "i": "int32_t", "f": "float"}


def _float(x: float) -> str:
    return f"{float(x)!r}f"


def c_header() -> str:
    """The text of ``iwp_protocol.h``."""
    o = ["/* iwp_protocol.h: the wire protocol's dictionary for the firmware.",
         " * GENERATED from iwp.device.protocol by tools/gen_protocol_header.py: do not edit. */",
         "#ifndef IWP_PROTOCOL_H", "#define IWP_PROTOCOL_H", "",
         f"#define IWP_PROTOCOL_VERSION {PROTOCOL_VERSION}",
         f"#define IWP_DICT_HASH 0x{DICTIONARY_HASH:08x}UL",
         f"#define IWP_MAX_PAYLOAD {MAX_PAYLOAD}", "",
         "/* messages: type byte, payload size, byte offset of each field (little-endian, packed) */"]
    for m in MESSAGES.values():
        o.append(f"#define IWP_MSG_{m.name} 0x{m.id:02x}")
        o.append(f"#define IWP_MSG_{m.name}_SIZE {m.size}")
        for f in m.fields:
            o.append(f"#define IWP_OFF_{m.name}_{f.name.upper()} {m.offsets()[f.name]} /* {_C_TYPES[f.code]}, "
                     f"{f.unit} */")
    for prefix, table in (("STATE", STATES), ("FAULT", FAULTS), ("FLAG", FLAGS), ("CAP", CAPS), ("MODE", MODES),
                          ("ACK", ACK_CODES), ("FIXTURE", FIXTURE_ACTIONS)):
        o.append("")
        o.extend(f"#define IWP_{prefix}_{k} {v}" for k, v in table.items())
    o.append("")
    o.append("/* parameters: id, then IWP_PARAM_TABLE rows {default, lo, hi} in id order */")
    o.extend(f"#define IWP_P_{p.name.upper()} {p.id} /* {p.unit}: {p.doc} */" for p in PARAMS.values())
    o.append(f"#define IWP_N_PARAMS {len(PARAMS)}")
    rows = ", \\\n    ".join(f"{{{_float(p.default)}, {_float(p.lo)}, {_float(p.hi)}}}" for p in PARAMS.values())
    o.append(f"#define IWP_PARAM_TABLE {{ \\\n    {rows} }}")
    o += ["", "#endif /* IWP_PROTOCOL_H */", ""]
    return "\n".join(o)
