!> The coloured-residual bracket sum_i sum_j a(i)' K(i-j) a(j) (mlid_colored)
!> through the Fourier transform, by the direct FIR filter, and as the core
!> takes it (the cheaper per segment), side by side in one run, at the sizes
!> of the real cases: ATTAS regression test case 23 (ny 6, N 2128, nf 20)
!> and flight-path test case 33 (ny 7, nf 34), lags 1 and 212, one
!> manoeuvre and three.  Also the largest relative difference of the two.
!>
!>     ninja -C build benchmarks/bench_colored_bracket && build/benchmarks/bench_colored_bracket
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
