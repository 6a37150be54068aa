//! The board the image is built for (cargo feature, chosen at build time): its memory map and
//! the serial port of the processor-in-the-loop link. Included by each binary with
//! `#[path = "../board.rs"] mod board;` (the binaries share no library crate).
//!
//! - default: QEMU's `mps2-an386` (Cortex-M4F; code SSRAM 0x0000_0000 and data SSRAM
//!   0x2000_0000, 4 MiB each; CMSDK APB UART0 at 0x4000_4000).
//! - `stm32f407`: STM32F405xG/F407xG (1 MiB flash at 0x0800_0000, 112 + 16 KiB SRAM1/SRAM2
//!   contiguous at 0x2000_0000; the 64 KiB CCM is unused). The same image is flashed to an
//!   STM32F407 board and run in QEMU's `netduinoplus2` (STM32F405). Serial: USART1
//!   (PA9 TX, PA10 RX, AF7) at 115,200 baud from the 16 MHz HSI, the clock after reset (the
//!   image never changes the clock tree). QEMU models neither RCC, GPIO nor the baud rate:
//!   there the writes to them change nothing.
#![allow(dead_code, unused_imports)] // each binary uses a part

/// Name of the board configuration (printed by the test runner).
#[cfg(not(feature = "stm32f407"))]
pub const NAME: &str = "mps2-an386";
/// Name of the board configuration (printed by the test runner).
#[cfg(feature = "stm32f407")]
pub const NAME: &str = "stm32f407 (STM32F405xG/F407xG memory map)";

/// Flash (code) origin and length in bytes, as in the linker's `memory.x`.
#[cfg(not(feature = "stm32f407"))]
pub const FLASH: (usize, usize) = (0x0000_0000, 4 << 20);
/// RAM origin and length in bytes, as in the linker's `memory.x`.
#[cfg(not(feature = "stm32f407"))]
pub const RAM: (usize, usize) = (0x2000_0000, 4 << 20);
/// Flash (code) origin and length in bytes, as in the linker's `memory.x`.
#[cfg(feature = "stm32f407")]
pub const FLASH: (usize, usize) = (0x0800_0000, 1 << 20);
/// RAM origin and length in bytes, as in the linker's `memory.x`.
#[cfg(feature = "stm32f407")]
pub const RAM: (usize, usize) = (0x2000_0000, 128 << 10);

/// Whether `addr` lies in the region `(origin, len)`.
pub fn contains(region: (usize, usize), addr: usize) -> bool {
    addr >= region.0 && addr - region.0 < region.1
}

#[cfg(not(feature = "stm32f407"))]
mod serial {
    const UART0: usize = 0x4000_4000;
    const DATA: *mut u32 = UART0 as *mut u32;
    const STATE: *mut u32 = (UART0 + 0x04) as *mut u32;
    const CTRL: *mut u32 = (UART0 + 0x08) as *mut u32;
    const BAUDDIV: *mut u32 = (UART0 + 0x10) as *mut u32;

    /// Enables UART0's transmitter and receiver.
    pub fn init() {
        // SAFETY: CMSDK APB UART0 registers of the mps2-an386 board, word-aligned MMIO.
        unsafe {
            BAUDDIV.write_volatile(16);
            CTRL.write_volatile(0b11);
        }
    }

    /// Waits for a received byte and returns it.
    pub fn read_byte() -> u8 {
        // SAFETY: as in `init`.
        unsafe {
            while STATE.read_volatile() & 0b10 == 0 {}
            (DATA.read_volatile() & 0xFF) as u8
        }
    }

    /// Waits until the transmitter has room, then sends `b`.
    pub fn write_byte(b: u8) {
        // SAFETY: as in `init`.
        unsafe {
            while STATE.read_volatile() & 0b01 != 0 {}
            DATA.write_volatile(u32::from(b));
        }
    }
}

#[cfg(feature = "stm32f407")]
mod serial {
    const RCC_AHB1ENR: *mut u32 = 0x4002_3830 as *mut u32;
    const RCC_APB2ENR: *mut u32 = 0x4002_3844 as *mut u32;
    const GPIOA_MODER: *mut u32 = 0x4002_0000 as *mut u32;
    const GPIOA_AFRH: *mut u32 = 0x4002_0024 as *mut u32;
    const USART1: usize = 0x4001_1000;
    const SR: *mut u32 = USART1 as *mut u32;
    const DR: *mut u32 = (USART1 + 0x04) as *mut u32;
    const BRR: *mut u32 = (USART1 + 0x08) as *mut u32;
    const CR1: *mut u32 = (USART1 + 0x0C) as *mut u32;
    /// SR: receive register not empty, transmit register empty.
    const RXNE: u32 = 1 << 5;
    const TXE: u32 = 1 << 7;
    /// CR1: USART enable, transmitter enable, receiver enable.
    const UE_TE_RE: u32 = (1 << 13) | (1 << 3) | (1 << 2);
    /// 16 MHz / (16 * 115,200) = 8.68: mantissa 8, fraction 11/16 (0.3 % off 115,200).
    const BRR_115200_AT_HSI: u32 = (8 << 4) | 11;

    /// Clocks GPIOA and USART1, puts PA9/PA10 on AF7 and enables USART1 (8N1, 115,200 baud).
    pub fn init() {
        // SAFETY: RCC, GPIOA and USART1 registers of the STM32F405/F407 (reference manual
        // RM0090), word-aligned MMIO; read-modify-write keeps the other bits.
        unsafe {
            RCC_AHB1ENR.write_volatile(RCC_AHB1ENR.read_volatile() | 1); // GPIOAEN
            RCC_APB2ENR.write_volatile(RCC_APB2ENR.read_volatile() | (1 << 4)); // USART1EN
            let moder = GPIOA_MODER.read_volatile() & !(0b1111 << 18);
            GPIOA_MODER.write_volatile(moder | (0b1010 << 18)); // PA9, PA10: alternate function
            let afrh = GPIOA_AFRH.read_volatile() & !(0xFF << 4);
            GPIOA_AFRH.write_volatile(afrh | (0x77 << 4)); // AF7 = USART1
            BRR.write_volatile(BRR_115200_AT_HSI);
            CR1.write_volatile(UE_TE_RE);
        }
    }

    /// Waits for a received byte and returns it.
    pub fn read_byte() -> u8 {
        // SAFETY: as in `init`.
        unsafe {
            while SR.read_volatile() & RXNE == 0 {}
            (DR.read_volatile() & 0xFF) as u8
        }
    }

    /// Waits until the transmit register is empty, then sends `b`.
    pub fn write_byte(b: u8) {
        // SAFETY: as in `init`.
        unsafe {
            while SR.read_volatile() & TXE == 0 {}
            DR.write_volatile(u32::from(b));
        }
    }
}

pub use serial::{init as serial_init, read_byte, write_byte};
