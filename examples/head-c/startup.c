/* Reset and fault vectors of examples/head-c on a Cortex-M4F: copy .data, zero .bss, enable the
 * FPU (the library uses the hard-float ABI), call main. A fault stops QEMU with a failure. */
#include <stdint.h>

#include "semihost.h"

extern uint32_t _data_load[], _data_start[], _data_end[], _bss_start[], _bss_end[];
extern uint32_t _stack_top[];
int main(void);

void reset_handler(void) {
    uint32_t *src = _data_load, *dst = _data_start;
    while (dst < _data_end) *dst++ = *src++;
    for (dst = _bss_start; dst < _bss_end; dst++) *dst = 0;
    /* CPACR: full access to CP10 and CP11 (the FPU). */
    *(volatile uint32_t *)0xE000ED88 |= 0xFu << 20;
    __asm volatile("dsb\n\tisb" ::: "memory");
    semihost_exit(main() == 0);
}

static void fault_handler(void) {
    semihost_print("fringe3d-head-c: fault\n");
    semihost_exit(0);
}

__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))_stack_top, reset_handler, fault_handler, fault_handler, fault_handler,
    fault_handler, fault_handler, 0, 0, 0, 0, fault_handler, fault_handler, 0, fault_handler,
    fault_handler,
};
