//! Controller scenario checks shared by the host tests and the Cortex-M4
//! build run under QEMU: the same test bodies on both.
