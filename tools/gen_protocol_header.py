"""Write the firmware's protocol header from the one dictionary (iwp.device.protocol).

    python tools/gen_protocol_header.py

writes src/iwp/device/csrc/iwp_protocol.h (firmware/core/ points there); the
test suite checks that the shipped header is what this writes.
"""

from iwp.device.cheader import HEADER_PATH, c_header

if __name__ == "__main__":
    HEADER_PATH.write_text(c_header())
    print(f"wrote {HEADER_PATH}")
