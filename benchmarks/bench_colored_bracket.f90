!> The coloured-residual bracket sum_i sum_j a(i)' K(i-j) a(j) (mlid_colored)
!> through the Fourier transform, by the direct FIR filter, and as the core
!> takes it (the cheaper per segment), side by side in one run, at the sizes
!> of the real cases: ATTAS regression test case 23 (ny 6, N 2128, nf 20)
!> and flight-path test case 33 (ny 7, nf 34), lags 1 and 212, one
!> manoeuvre and three.  Also the largest relative difference of the two.
!>
!>     ninja -C build benchmarks/bench_colored_bracket && build/benchmarks/bench_colored_bracket
!>
!> Measured (ours, one thread, main at d84cbd5 and branch colored-fast built
!> alike, -O3, run in turn three times; middle of three, ms, shared machine):
!>   ny nf lag segs   fourier       direct        core
!>    6 20   1  1     8.6 -> 6.0    5.8 -> 3.4    5.6 -> 3.4
!>    6 20 212  1     7.0 -> 6.6  128.0 -> 60.6   6.2 -> 6.6
!>    6 20 212  3     3.8 -> 3.4  122.0 -> 52.6   3.8 -> 3.0
!>    7 34   1  1    22.8 -> 12.8  17.8 -> 9.0   17.0 -> 8.8
!>    7 34 212  1    23.0 -> 15.0 255.4 -> 150.0 22.2 -> 14.0
!>    7 34 212  3     9.0 -> 7.2  238.8 -> 131.6  9.0 -> 7.2
!> The two ways' largest relative difference 3e-15 - 1.1e-14 -> 5e-16 - 1.9e-15
!> (the transform's series scaled by powers of two before they share one).
program bench_colored_bracket
  use mlid_kinds, only: wp
  use mlid_colored, only: colored_bracket, BRACKET_AUTO, BRACKET_FOURIER, BRACKET_DIRECT
  implicit none
  integer, parameter :: REPEAT = 5
  integer :: sizes(2, 2), lags(2), segs(3), c
  sizes = reshape([6, 20, 7, 34], [2, 2])
  lags = [1, 212]
  segs = [1, 627, 1378]                      ! the three ATTAS manoeuvres
  write (*, '(a4,a4,a6,a6,3a12,a12)') 'ny', 'nf', 'lag', 'segs', 'fourier ms', 'direct ms', &
    'core ms', 'rel. diff'
  do c = 1, 2
    call run(sizes(1, c), sizes(2, c), lags(1), segs(1:1))
    call run(sizes(1, c), sizes(2, c), lags(2), segs(1:1))
    call run(sizes(1, c), sizes(2, c), lags(2), segs)
  end do

contains

  subroutine run(ny, nf, lag, seg)
    integer, intent(in) :: ny, nf, lag, seg(:)
    integer, parameter :: nt = 2128
    real(wp), allocatable :: a(:, :, :), rvv(:, :, :), b(:, :, :)
    real(wp) :: ms(3)
    integer :: k, how, c0, c1, rate
    integer, parameter :: HOWS(3) = [BRACKET_FOURIER, BRACKET_DIRECT, BRACKET_AUTO]
    allocate (a(ny, nt, nf), rvv(ny, ny, 0:lag), b(nf, nf, 3))
    call random_number(a)
    call random_number(rvv)
    do how = 1, 3
      call system_clock(c0, rate)
      do k = 1, REPEAT
        b(:, :, how) = colored_bracket(a, rvv, seg, HOWS(how))
      end do
      call system_clock(c1)
      ms(how) = 1000.0_wp*(c1 - c0)/rate/REPEAT
    end do
    write (*, '(i4,i4,i6,i6,3f12.2,es12.2)') ny, nf, lag, size(seg), ms, &
      maxval(abs(b(:, :, 1) - b(:, :, 2)))/maxval(abs(b(:, :, 2)))
  end subroutine run

end program bench_colored_bracket
