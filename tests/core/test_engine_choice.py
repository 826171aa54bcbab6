"""The "auto" engine rule (grasswidget.core.engine_choice): one test per outcome of its table."""

from __future__ import annotations

import pytest

from grasswidget.core.engine_choice import choose_engine, page_adapter_kind, page_adapter_name
from grasswidget.errors import GrassError

# What Chromium's adapter probe reports here (headless, --use-webgpu-adapter=swiftshader).
SWIFTSHADER = {"webgpu": True, "adapter": True, "fallback": False, "vendor": "google",
               "architecture": "swiftshader", "device": "", "description": "", "detail": ""}
NVIDIA = {"webgpu": True, "adapter": True, "fallback": False, "vendor": "nvidia", "architecture": "ampere",
          "device": "", "description": "", "detail": ""}
NO_ADAPTER = {"webgpu": True, "adapter": False, "detail": "requestAdapter() gave null"}
NO_WEBGPU = {"webgpu": False, "adapter": False, "detail": "navigator.gpu is missing"}


def test_kernel_on_a_gpu_keeps_the_kernel_engine_whatever_the_page():
    for page in (None, NVIDIA, SWIFTSHADER, NO_WEBGPU):
        choice = choose_engine("gpu", "NVIDIA H100", page)
        assert choice.engine == "kernel"
        assert choice.reason == "kernel engine: the kernel renders on a GPU (NVIDIA H100)"


def test_cpu_kernel_and_a_hardware_adapter_in_the_page_run_the_browser_engine():
    choice = choose_engine("cpu", "llvmpipe", NVIDIA)
    assert (choice.engine, choice.page) == ("browser", "hardware")
    assert choice.reason == ("browser engine: the kernel renders on a CPU adapter (llvmpipe) and this browser "
                             "offers a GPU (nvidia ampere)")
    # A browser that does not say isFallbackAdapter (older Chrome, Safari) with a GPU's name: hardware too.
    assert choose_engine("cpu", "llvmpipe", dict(NVIDIA, fallback=None)).engine == "browser"
    assert choose_engine("cpu", "llvmpipe", {"webgpu": True, "adapter": True, "vendor": "apple",
                                             "architecture": "metal-3"}).engine == "browser"


@pytest.mark.parametrize("page", [
    SWIFTSHADER,                                                            # SwiftShader by name (Chromium)
    dict(NVIDIA, fallback=True),                                            # isFallbackAdapter says so
    dict(NVIDIA, vendor="mesa", architecture="", description="llvmpipe (LLVM 15.0.6, 256 bits)"),
    dict(NVIDIA, vendor="microsoft", architecture="", description="Microsoft Basic Render Driver"),
    dict(NVIDIA, vendor="", architecture="", device="CPU"),
], ids=["swiftshader", "isFallbackAdapter", "llvmpipe", "warp", "cpu-device"])
def test_cpu_kernel_and_a_fallback_adapter_in_the_page_keep_the_kernel_engine(page):
    choice = choose_engine("cpu", "llvmpipe", page)
    assert (choice.engine, choice.page) == ("kernel", "fallback")
    assert choice.reason.startswith("kernel engine: the kernel renders on a CPU adapter (llvmpipe) and this "
                                    "browser's WebGPU adapter is a CPU fallback too")


def test_names_that_only_contain_a_marker_are_not_fallbacks():
    # "cpu" counts as a whole word only: an architecture that merely contains the letters is a GPU.
    assert page_adapter_kind(dict(NVIDIA, architecture="gcpu-9")) == "hardware"


@pytest.mark.parametrize("page", [NO_ADAPTER, NO_WEBGPU, "garbage", {"adapter": True}],
                         ids=["no-adapter", "no-webgpu", "not-a-dict", "no-webgpu-key"])
def test_cpu_kernel_and_no_webgpu_in_the_page_keep_the_kernel_engine(page):
    choice = choose_engine("cpu", "llvmpipe", page)
    assert (choice.engine, choice.page) == ("kernel", "none")
    assert "WebGPU is not available in this browser" in choice.reason
    if isinstance(page, dict) and page.get("detail"):
        assert f"({page['detail']})" in choice.reason


def test_cpu_kernel_before_any_report_runs_the_kernel_engine():
    choice = choose_engine("cpu", "llvmpipe", None)
    assert (choice.engine, choice.page) == ("kernel", None)
    assert "no view has reported" in choice.reason


def test_no_kernel_adapter_runs_the_browser_engine_where_the_page_has_any_adapter():
    assert choose_engine("none", "", None).engine == "browser"
    assert choose_engine("none", "", NVIDIA).engine == "browser"
    assert choose_engine("none", "", SWIFTSHADER).engine == "browser"  # a fallback beats nothing
    choice = choose_engine("none", "", NO_WEBGPU)
    assert choice.engine == "kernel" and "nothing can draw here" in choice.reason


def test_page_adapter_name_and_bad_kernel_kind():
    assert page_adapter_name(SWIFTSHADER) == "google swiftshader"
    assert page_adapter_name(dict(NVIDIA, description="NVIDIA")) == "nvidia ampere"  # no repeats
    assert page_adapter_name(None) == ""
    with pytest.raises(GrassError, match="kernel_kind must be one of 'gpu', 'cpu', 'none'; got 'tpu'"):
        choose_engine("tpu")
    with pytest.raises(ValueError):
        choose_engine("tpu")
