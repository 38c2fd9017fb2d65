/* iwp_frame.c: CRC-16/CCITT-FALSE and COBS (see iwp_frame.h). */
#include "iwp_frame.h"

#ifdef __AVR__
#include <util/crc16.h>
#endif

uint16_t iwp_crc16_update(uint16_t crc, uint8_t byte)
{
#ifdef __AVR__
    return _crc_xmodem_update(crc, byte); /* avr-libc's hand-written form of the same polynomial */
#endif
    /* the byte-wise form of the 0x1021 polynomial (no table: 32 bytes of RAM saved on the AVR) */
    uint8_t x = (uint8_t)((crc >> 8) ^ byte);
    x ^= (uint8_t)(x >> 4);
    return (uint16_t)((crc << 8) ^ ((uint16_t)x << 12) ^ ((uint16_t)x << 5) ^ (uint16_t)x);
}

uint16_t iwp_crc16(const uint8_t *data, uint16_t n)
{
    uint16_t crc = 0xFFFF;
    for (uint16_t i = 0; i < n; i++) crc = iwp_crc16_update(crc, data[i]);
    return crc;
}

uint16_t iwp_cobs_encode(const uint8_t *src, uint16_t n, uint8_t *dst)
{
    uint16_t code_at = 0, out = 1;
    uint8_t code = 1;
    for (uint16_t i = 0; i < n; i++) {
        if (src[i] == 0) {
            dst[code_at] = code;
            code_at = out++;
            code = 1;
        } else {
            dst[out++] = src[i];
            if (++code == 0xFF) {
                dst[code_at] = code;
                code_at = out++;
                code = 1;
            }
        }
    }
    dst[code_at] = code;
    return out;
}

int16_t iwp_cobs_decode_inplace(uint8_t *buf, uint16_t n)
{
    uint16_t in = 0, out = 0;
    while (in < n) {
        uint8_t code = buf[in];
        if (code == 0 || (uint16_t)(in + code) > n) return -1;
        in++;
        for (uint8_t i = 1; i < code; i++) {
            if (buf[in] == 0) return -1;
            buf[out++] = buf[in++];
        }
        if (code != 0xFF && in < n) buf[out++] = 0;
    }
    return (int16_t)out;
}
