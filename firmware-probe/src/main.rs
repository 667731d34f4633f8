//! Firmware-like probe of `pumptwin-core` on a Cortex-M4F (`thumbv7em-none-eabihf`):
//! decode the shipped int8 model from flash into a static, build the int8 DS-STGAT,
//! run one inference on the first golden window, check the logit codes exactly, and
//! measure the peak stack of each phase by painting the free stack. Output and exit
//! status go through semihosting (QEMU `mps2-an386`, see `run.sh`).

#![no_std]
#![no_main]

use core::arch::asm;
use core::fmt::Write as _;
#[cfg(not(feature = "net-on-stack"))]
use core::mem::ManuallyDrop;
use core::mem::{size_of, MaybeUninit};
use core::ptr::{addr_of, addr_of_mut};

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio};
use pumptwin_core::dsstgat::{DsStgat, Output, Scratch};
use pumptwin_core::graph::NodeMask;
use pumptwin_core::model_file::{self, ModelFile};

mod golden {
    use pumptwin_core::graph::Adjacency;
    include!(concat!(env!("OUT_DIR"), "/golden.rs"));
}
use golden::{F, N, T};

/// The shipped model's int8 network: `F` = 28 features, `H` = 32, its classes
/// (`golden::CLASSES`, 10: a firmware is built for the model it ships; each class of
/// room more costs a row of the classifier and of the sensor head, about 100 B of RAM) and
/// room for 8 indicators (the shipped head is zero-padded up to these).
type Net = DsStgat<F, 32, { golden::CLASSES }, 8>;
type NetScratch = Scratch<T, N, F, 32>;
type NetOutput = Output<{ golden::CLASSES }, 8>;

/// The shipped model file, in flash.
static MODEL_BYTES: &[u8] = include_bytes!("../../models/dsstgat-cwru-tb.ptm");

// ---------------------------------------------------------------------------------
// Storage the firmware owns: `ARENA` (zeroed, .bss) and `NET` (.data, see it).
// ---------------------------------------------------------------------------------

/// The decoded model and the inference scratch share one region: the model is read
/// only while the network is built, the scratch only while it runs, so the scratch
/// takes the model's place after the build (`main` writes `Scratch::new()` over it).
/// All-zero is a valid `ModelFile`: its fields are integers, floats and `heapless`
/// `Vec`/`String`s (a length and a `MaybeUninit` buffer), so a zeroed value is a model
/// with empty buffers, which `decode_into` then overwrites.
#[cfg(not(feature = "net-on-stack"))]
#[allow(dead_code)] // accessed through casts: the union gives the size and alignment of both
union Arena {
    model: ManuallyDrop<MaybeUninit<ModelFile>>,
    scratch: ManuallyDrop<NetScratch>,
}
#[cfg(not(feature = "net-on-stack"))]
static mut ARENA: MaybeUninit<Arena> = MaybeUninit::zeroed();
/// The int8 network, filled in place once by `DsStgat::load` (starts as the const
/// `DsStgat::EMPTY`, so it is `.data`: its placeholder scales are not zero).
#[cfg(not(feature = "net-on-stack"))]
static mut NET: Net = Net::EMPTY;
/// `net-on-stack` builds the network while it runs, so model and scratch are apart.
#[cfg(feature = "net-on-stack")]
static mut MODEL: MaybeUninit<ModelFile> = MaybeUninit::zeroed();
#[cfg(feature = "net-on-stack")]
static mut SCRATCH: NetScratch = Scratch::new();

// ---------------------------------------------------------------------------------
// Stack painting
// ---------------------------------------------------------------------------------

extern "C" {
    /// cortex-m-rt: the first free RAM address after .data/.bss/.uninit (the bottom
    /// of the region the stack may grow into).
    static __sheap: u32;
    /// cortex-m-rt: the initial stack pointer, `ORIGIN(RAM) + LENGTH(RAM)`.
    static _stack_start: u32;
}

const PAINT: u32 = 0xDEAD_BEEF;

fn stack_bottom() -> usize {
    // Only the address of the linker symbol is taken (no read: safe).
    (addr_of!(__sheap) as usize + 3) & !3
}

fn stack_top() -> usize {
    // Only the address of the linker symbol is taken (no read: safe).
    addr_of!(_stack_start) as usize
}

#[inline(never)]
fn sp() -> usize {
    let sp: usize;
    // SAFETY: reads the stack pointer.
    unsafe { asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

/// Fill the free stack, from the bottom up to (not including) the current stack
/// pointer, with [`PAINT`]. All in assembly: a Rust loop may read the SP before its
/// own prologue pushes (shrink-wrapping) and paint over its return address. Nothing
/// else runs meanwhile (no interrupts are enabled).
#[inline(always)]
fn paint() {
    if cfg!(feature = "no-paint") {
        return;
    }
    // SAFETY: writes only [bottom, sp): unused stack, no live data lives below the SP.
    unsafe {
        asm!(
            "mov {end}, sp",
            "bic {end}, {end}, #3",
            "2:",
            "cmp {p}, {end}",
            "bhs 3f",
            "str {pat}, [{p}], #4",
            "b 2b",
            "3:",
            p = inout(reg) stack_bottom() => _,
            end = out(reg) _,
            pat = in(reg) PAINT,
            options(nostack),
        );
    }
}

/// Peak stack since the last [`paint`], measured from the initial SP (so it includes
/// the reset handler's and `main`'s frames): `_stack_start` minus the lowest word
/// that no longer holds the paint.
#[inline(never)]
fn peak_stack() -> usize {
    if cfg!(feature = "no-paint") {
        return 0;
    }
    let top = stack_top();
    let mut p = stack_bottom();
    while p < top {
        // SAFETY: reads RAM within [bottom, top).
        if unsafe { core::ptr::read_volatile(p as *const u32) } != PAINT {
            break;
        }
        p += 4;
    }
    top - p
}

// ---------------------------------------------------------------------------------
// The three phases, each its own frame so that its stack can be told apart.
// ---------------------------------------------------------------------------------

#[inline(never)]
fn phase_decode(model: &mut ModelFile) -> pumptwin_core::Result<()> {
    model_file::decode_into(core::hint::black_box(MODEL_BYTES), model)
}

#[cfg(not(feature = "net-on-stack"))]
#[inline(never)]
fn phase_build<'a>(model: &ModelFile, place: &'a mut Net) -> pumptwin_core::Result<&'a Net> {
    place.load(model)?;
    Ok(place)
}

#[cfg(not(feature = "net-on-stack"))]
#[inline(never)]
fn phase_forward(
    net: &Net,
    scratch: &mut NetScratch,
    out: &mut NetOutput,
) -> pumptwin_core::Result<()> {
    net.forward::<T, N>(
        core::hint::black_box(&golden::X),
        core::hint::black_box(&golden::ADJ),
        &NodeMask(golden::MASK),
        out,
        scratch,
    )
}

/// `net-on-stack`: the network is a local of the function that runs it.
#[cfg(feature = "net-on-stack")]
#[inline(never)]
fn phase_build_and_forward(
    model: &ModelFile,
    scratch: &mut NetScratch,
    out: &mut NetOutput,
) -> pumptwin_core::Result<()> {
    let net = Net::from_model_file(model)?;
    net.forward::<T, N>(
        core::hint::black_box(&golden::X),
        core::hint::black_box(&golden::ADJ),
        &NodeMask(golden::MASK),
        out,
        scratch,
    )
}

// ---------------------------------------------------------------------------------

/// Semihosting stdout (opened once; `hio::hstdout` costs a host call each time).
struct Console(Option<hio::HostStream>);

impl core::fmt::Write for Console {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        match &mut self.0 {
            Some(h) => h.write_str(s),
            None => Ok(()),
        }
    }
}

macro_rules! say {
    ($c:expr, $($arg:tt)*) => {{ let _ = writeln!($c, $($arg)*); }};
}

fn fail(c: &mut Console, what: &str, e: pumptwin_core::Error) -> ! {
    say!(c, "FAIL: {}: {:?}", what, e);
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

#[entry]
fn main() -> ! {
    let mut c = Console(hio::hstdout().ok());
    let top = stack_top();
    let bottom = stack_bottom();
    let before = top - sp();
    print_banner(&mut c, bottom, top, before);

    // SAFETY: `main` runs once and is the only code touching these statics. The zeroed
    // arena is a valid `ModelFile` (see `Arena`); the model borrow ends with the build,
    // before the scratch is written over it.
    #[cfg(not(feature = "net-on-stack"))]
    let model: &mut ModelFile = unsafe {
        (*addr_of_mut!(ARENA))
            .as_mut_ptr()
            .cast::<ModelFile>()
            .as_mut()
            .unwrap_or_else(|| halt())
    };
    #[cfg(feature = "net-on-stack")]
    let (model, scratch) = unsafe {
        (
            (*addr_of_mut!(MODEL)).assume_init_mut(),
            &mut *addr_of_mut!(SCRATCH),
        )
    };
    let mut out = NetOutput::default();

    let s_decode = decode(&mut c, model);
    #[cfg(not(feature = "net-on-stack"))]
    {
        let (net, s_build) = build_in_static(&mut c, model);
        // `model` is not used again: the scratch takes its place.
        let s_forward = forward_over_model(&mut c, net, &mut out);
        say!(
            c,
            "STACK decode={} build={} forward={} max={}",
            s_decode,
            s_build,
            s_forward,
            s_decode.max(s_build).max(s_forward)
        );
    }
    #[cfg(feature = "net-on-stack")]
    {
        let s_both = build_and_forward_on_stack(&mut c, model, scratch, &mut out);
        say!(
            c,
            "STACK decode={} build+forward={} max={}",
            s_decode,
            s_both,
            s_decode.max(s_both)
        );
    }

    print_logits(&mut c, &out);
    check_golden(&mut c, &out)
}

// The steps of `main`. Each is `#[inline(always)]`: they run in `main`'s frame, as
// before they were split out, so that the painted peaks (measured from the initial
// SP) count the same frames; only the `phase_*` functions have frames of their own.

/// The probe's banner: model, type sizes and the stack region (`[bottom, top)`, of
/// which `before` bytes were in use before painting).
#[inline(always)]
fn print_banner(c: &mut Console, bottom: usize, top: usize, before: usize) {
    say!(c, "pumptwin firmware probe (thumbv7em-none-eabihf)");
    say!(
        c,
        "model sha256 {} (checked at build time)",
        golden::MODEL_SHA256
    );
    say!(
        c,
        "model file {} B in flash; size_of ModelFile {} B, DsStgat<F,32,C,8> {} B, Scratch<8,3,F,32> {} B, Output {} B",
        MODEL_BYTES.len(),
        size_of::<ModelFile>(),
        size_of::<Net>(),
        size_of::<NetScratch>(),
        size_of::<NetOutput>()
    );
    {
        use pumptwin_core::quant::{GatLayer, GruCell, QLinear};
        say!(
            c,
            "size_of QLinear<32,32> {} B, GatLayer<32,32> {} B, GruCell<32,32> {} B, Result<DsStgat> {} B",
            size_of::<QLinear<32, 32>>(),
            size_of::<GatLayer<32, 32>>(),
            size_of::<GruCell<32, 32>>(),
            size_of::<pumptwin_core::Result<Net>>()
        );
    }
    say!(
        c,
        "stack region [{:#010x}, {:#010x}) = {} B; used before painting {} B",
        bottom,
        top,
        top - bottom,
        before
    );
}

/// (a) Decode the model from flash into `model`; says its dimensions and returns the
/// phase's peak stack.
#[inline(always)]
fn decode(c: &mut Console, model: &mut ModelFile) -> usize {
    paint();
    let r = phase_decode(model);
    let s_decode = peak_stack();
    if let Err(e) = r {
        fail(c, "decode_into", e);
    }
    say!(
        c,
        "decoded '{}': N={} F={} T={} H={}/{} C={} K={}",
        model.model_name.as_str(),
        model.dims.nodes,
        model.dims.features,
        model.dims.steps,
        model.dims.gat_hidden,
        model.dims.gru_hidden,
        model.dims.classes,
        model.dims.indicators
    );
    say!(c, "stack peak (a) decode_into:      {:6} B", s_decode);
    s_decode
}

/// (b) Build the network into its static `NET`; returns it and the phase's peak stack.
#[cfg(not(feature = "net-on-stack"))]
#[inline(always)]
fn build_in_static(c: &mut Console, model: &ModelFile) -> (&'static Net, usize) {
    // SAFETY: borrowed once, see `main`.
    let place = unsafe { &mut *addr_of_mut!(NET) };
    paint();
    let r = phase_build(model, place);
    let s_build = peak_stack();
    let net = match r {
        Ok(net) => net,
        Err(e) => fail(c, "from_model_file", e),
    };
    say!(
        c,
        "stack peak (b) DsStgat::load:    {:6} B (network in a static, built in place)",
        s_build
    );
    (net, s_build)
}

/// (c) One inference into `out`, its scratch in the arena over the decoded model
/// (which must no longer be read); returns the phase's peak stack.
#[cfg(not(feature = "net-on-stack"))]
#[inline(always)]
fn forward_over_model(c: &mut Console, net: &Net, out: &mut NetOutput) -> usize {
    // The model is no longer read: the scratch takes its place, zeroed in place
    // (a `Scratch` is integer arrays only, so all-zero bytes are `Scratch::new()`;
    // writing `Scratch::new()` by value would first build it on the stack).
    // SAFETY: the arena is aligned and sized for both members; `model` is not used
    // again; every bit pattern of integer arrays is a valid value.
    let scratch: &mut NetScratch = unsafe {
        let p = (*addr_of_mut!(ARENA)).as_mut_ptr().cast::<NetScratch>();
        core::ptr::write_bytes(p, 0, 1);
        &mut *p
    };

    paint();
    let r = phase_forward(net, scratch, out);
    let s_forward = peak_stack();
    if let Err(e) = r {
        fail(c, "forward", e);
    }
    say!(c, "stack peak (c) forward::<8, 3>:  {:6} B", s_forward);
    s_forward
}

/// (b+c) `net-on-stack`: build the network as a local and run it into `out`; returns
/// the phase's peak stack.
#[cfg(feature = "net-on-stack")]
#[inline(always)]
fn build_and_forward_on_stack(
    c: &mut Console,
    model: &ModelFile,
    scratch: &mut NetScratch,
    out: &mut NetOutput,
) -> usize {
    paint();
    let r = phase_build_and_forward(model, scratch, out);
    let s_both = peak_stack();
    if let Err(e) = r {
        fail(c, "from_model_file + forward", e);
    }
    say!(
        c,
        "stack peak (b+c) from_model_file + forward, network on the stack: {:6} B",
        s_both
    );
    s_both
}

/// The logits and class, and the peak stack of that one print (the console itself:
/// formatting + semihosting) for reference.
#[inline(always)]
fn print_logits(c: &mut Console, out: &NetOutput) {
    paint();
    say!(
        c,
        "logits {:?} class {}",
        &out.logits[..golden::CLASSES],
        out.class
    );
    let s_print = peak_stack();
    say!(
        c,
        "stack peak of one formatted semihosting print: {} B",
        s_print
    );
}

/// Exit with success when the logit codes and class equal the golden ones exactly
/// (the padding logits zero), else say what was expected and exit with failure.
#[inline(always)]
fn check_golden(c: &mut Console, out: &NetOutput) -> ! {
    let ok = out.logits[..golden::CLASSES] == golden::INT8_LOGITS
        && out.logits[golden::CLASSES..].iter().all(|&v| v == 0)
        && out.class == golden::INT8_CLASS;
    if ok {
        say!(
            c,
            "PASS: int8 logit codes equal the golden codes exactly; class {}",
            out.class
        );
        debug::exit(debug::EXIT_SUCCESS);
    } else {
        say!(
            c,
            "expected {:?} class {}",
            golden::INT8_LOGITS,
            golden::INT8_CLASS
        );
        say!(c, "FAIL: int8 logits differ from the golden codes");
        debug::exit(debug::EXIT_FAILURE);
    }
    halt()
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    if let Ok(mut h) = hio::hstdout() {
        let _ = writeln!(h, "FAIL: HardFault at pc {:#010x}", ef.pc());
    }
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    if let Ok(mut h) = hio::hstdout() {
        let _ = writeln!(h, "FAIL: panic: {}", info);
    }
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

/// After a semihosting exit (which does not return under QEMU): sleep forever.
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
