//! The CMSDK APB UART of the MPS2 boards behind `embedded-io`.
//!
//! AN385/AN386 place UART0..4 at 0x4000_4000, 0x4000_5000, 0x4000_6000, 0x4000_7000 and
//! 0x4000_9000 (ARM AN386 memory map; QEMU hw/arm/mps2.c). Registers: DATA (+0x00), STATE
//! (+0x04: bit 0 TX full, bit 1 RX full), CTRL (+0x08: bit 0 TX enable, bit 1 RX enable), INT
//! (+0x0C), BAUDDIV (+0x10, at least 16).

use core::convert::Infallible;
use core::ptr::{read_volatile, write_volatile};

/// UART0's base address on AN385/AN386.
pub const UART0: usize = 0x4000_4000;
/// The APB clock of the MPS2 FPGA images, Hz.
pub const SYSCLK_HZ: u32 = 25_000_000;

const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const BAUDDIV: usize = 0x10;
const STATE_TX_FULL: u32 = 1;
const STATE_RX_FULL: u32 = 2;

/// One CMSDK UART, polled.
pub struct CmsdkUart {
    base: usize,
}

impl CmsdkUart {
    /// Enable the UART at `base` for transmit and receive at `baud`.
    ///
    /// # Safety
    /// `base` must be a CMSDK APB UART that nothing else drives.
    pub unsafe fn new(base: usize, baud: u32) -> Self {
        let u = CmsdkUart { base };
        let div = (SYSCLK_HZ / baud.max(1)).max(16);
        u.write_reg(BAUDDIV, div);
        u.write_reg(CTRL, 0b11);
        u
    }

    fn read_reg(&self, off: usize) -> u32 {
        // SAFETY: a register of the device this value owns (see `new`).
        unsafe { read_volatile((self.base + off) as *const u32) }
    }

    fn write_reg(&self, off: usize, v: u32) {
        // SAFETY: as above.
        unsafe { write_volatile((self.base + off) as *mut u32, v) }
    }
}

impl embedded_io::ErrorType for CmsdkUart {
    type Error = Infallible;
}

impl embedded_io::Write for CmsdkUart {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        for &b in buf {
            while self.read_reg(STATE) & STATE_TX_FULL != 0 {}
            self.write_reg(DATA, b as u32);
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        while self.read_reg(STATE) & STATE_TX_FULL != 0 {}
        Ok(())
    }
}

impl embedded_io::WriteReady for CmsdkUart {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.read_reg(STATE) & STATE_TX_FULL == 0)
    }
}

impl embedded_io::Read for CmsdkUart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        if buf.is_empty() {
            return Ok(0);
        }
        while self.read_reg(STATE) & STATE_RX_FULL == 0 {}
        let mut n = 0;
        while n < buf.len() && self.read_reg(STATE) & STATE_RX_FULL != 0 {
            buf[n] = self.read_reg(DATA) as u8;
            n += 1;
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for CmsdkUart {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.read_reg(STATE) & STATE_RX_FULL != 0)
    }
}
